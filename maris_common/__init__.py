"""Small utilities shared by every package (YAML with source positions, errors)."""
