import os

import jax


# Tests run in float64; float32 is tested explicitly where it matters.
jax.config.update("jax_enable_x64", True)
# No display is needed anywhere in the test suite.
os.environ.setdefault("MPLBACKEND", "Agg")
