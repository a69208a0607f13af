"""Many solves: sweeps, sampled studies, convergence, accuracy estimates; sampling, the
execution engines and families of cases that share one factorisation.
"""
