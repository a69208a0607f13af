"""Results on disk: the solution's post-processing (results, fields), the run directory,
report, VTU/NPZ writers, figures, atomic files and transactions.
"""
