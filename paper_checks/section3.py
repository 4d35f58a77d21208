"""Section 3 of the catalogue."""
