"""Independent test oracles (numpy/scipy only; they must not import shellcontact's model code)."""
