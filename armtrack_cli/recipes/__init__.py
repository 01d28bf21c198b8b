"""The bundled recipes (TOML files), shipped as package data and found by name."""
