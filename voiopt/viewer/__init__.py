"""The self-contained HTML plan viewer (voiopt show)."""
