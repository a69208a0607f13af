"""The case: the case file read into a typed, frozen Case; its solver options; its size.
"""
