"""Solve a case: discretise, set up the contact, solve, check (validity) and return a Result.
"""
