"""One BLAS thread while the fit's compiled programs run.

On CPU, JAX's Cholesky factorisation and triangular solves (`jax.scipy.linalg`, the
damped step of every solver iteration, `fitting._solver.damped_step`) call LAPACK through
scipy's OpenBLAS, which runs as many threads as cores. For the fit's matrices (n d + p
rows: 128 for a glyph at n = 64) the extra threads gain nothing, and after each call
they keep spinning for a while, taking cores from XLA's own thread pool, which runs
the rest of the program. With one OpenBLAS thread, fits of traced 1024-px glyphs took
0.63-0.64 of the time on 2 cores (STIXGeneral and DejaVu Serif 'S': 0.74 -> 0.46 s and
1.03 -> 0.66 s); the star at 1024 px, fits at 256 px, a `fit_params` fit and a
`fit_batch` took the same time within the noise (0.99-1.02;
`benchmarks/results/blas_threads.md`, both settings alternating in one process, on a
tree that differed from this one only in how the feet's curve was evaluated).

The limit holds only while a fit runs (threadpoolctl's controller, as scikit-learn
limits BLAS inside its own parallel sections): afterwards the process's BLAS settings
are the user's again.
"""

import contextlib
import functools


@functools.cache
def _controller():
    # scipy's LAPACK is what JAX's CPU kernels call; loaded here (JAX loads it lazily,
    # when a program with a factorisation is first lowered) so that the controller,
    # which lists the BLAS libraries loaded when it is made, sees it.
    import scipy.linalg.cython_lapack  # noqa: F401
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


@contextlib.contextmanager
def one_blas_thread():
    """Limit the loaded BLAS libraries to one thread inside the `with` block (the
    previous limits are restored on exit). Block on the results inside it: JAX
    dispatches programs asynchronously."""
    with _controller().limit(limits=1, user_api="blas"):
        yield
