"""Section 4 of the catalogue."""
