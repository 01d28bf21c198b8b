"""The I/O layer: session.toml, every reader of recorded data and every writer of outputs.

Only this package (and the CLI) touches files. Readers convert each file's conventions to the
contract's (SI units, z-up W, quaternions (w, x, y, z) rotating B into W) at the edge.
"""
