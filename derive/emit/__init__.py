"""Emitters: from :mod:`derive.models` specifications to code (C, CasADi, NumPy)."""
