"""How an input is declared and checked: the case file's key tables (schema), user functions,
--set overrides, the Python API's argument checks. Knows nothing of shells.
"""
