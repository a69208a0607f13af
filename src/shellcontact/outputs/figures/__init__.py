"""Figures, one module per kind; matplotlib is imported only here.
"""
