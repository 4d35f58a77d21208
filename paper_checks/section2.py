"""Section 2 of the catalogue."""
