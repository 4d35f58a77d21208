"""Checks of every catalogued equation and claim of Markeev (2012) against the derivation.

The paper's printed formulas are transcribed in :mod:`paper_checks.printed` (and nowhere
else in the project); each check in ``section1`` ... ``section4`` names its catalogue ID.
``CLAIMS.md`` here is a copy of ``../shared/paper/CLAIMS.md``, the catalogue the IDs come
from, so that the checks run on a clone that has no ``shared/`` beside it.
"""
