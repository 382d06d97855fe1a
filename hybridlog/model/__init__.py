"""Model files: TOML parsing, symbolic mode equations and their compiled form."""
