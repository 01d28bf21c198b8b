"""Core types, geometry and errors: numpy/scipy only, no files, no click."""
