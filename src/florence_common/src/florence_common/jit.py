"""numba kernels compiled on first use (ROS-free).

    _sight = lazy_njit(_sight_py)              # numba.njit(cache=True) of it, made at the first call
    _hits = lazy_njit(_hits_py, nogil=True)    # other numba.njit options as keywords

Importing numba and compiling cost every user of a module time, also those that never call the
kernel; the first call compiles it (or loads it from numba's on-disk cache, next to the module).
The plain Python function stays importable as it is (tests, a reading of the algorithm).
"""


class lazy_njit:
    def __init__(self, func, **options):
        self.func = func
        self.options = {"cache": True, **options}
        self._compiled = None

    def __call__(self, *args):
        if self._compiled is None:
            import numba

            self._compiled = numba.njit(**self.options)(self.func)
        return self._compiled(*args)
