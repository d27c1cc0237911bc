"""Kernels written once as plain Python functions, built compiled (numba) and interpreted.

A :class:`KernelSet` collects the kernels of one module. Each kernel is a plain function
marked with the set's decorator, which leaves it unchanged and registers it with numba
(``register_jitable``): a compiled kernel that calls it gets it compiled in (with the set's
options), while Python calls it as it is. :meth:`KernelSet.build` returns two namespaces
holding the same names:

- ``JIT``: every kernel as ``numba.njit(cache=True, **options)`` (compiled on first call,
  cached on disk in ``__pycache__``, so the next process loads it);
- ``PY``: the functions themselves, the pure-Python twin (same statements, interpreted).

``ABB_ROS_NO_JIT=1`` (or numba missing) makes JIT the twin, and numba is not imported.
Usage (a module of kernels)::

    kernel = KernelSet(error_model='numpy')

    @kernel
    def f(x): ...

    @kernel(parallel=True)          # options only for the compiled entry point f2
    def f2(x): ... f(x) ...

    JIT, PY = kernel.build()
"""

from __future__ import annotations

import os

__all__ = ['NO_JIT_ENV', 'enabled', 'prange', 'Kernels', 'KernelSet']

NO_JIT_ENV = 'ABB_ROS_NO_JIT'


def enabled() -> bool:
    """Return True when kernels are compiled: numba importable, ABB_ROS_NO_JIT unset or empty."""
    if os.environ.get(NO_JIT_ENV):
        return False
    try:
        import numba  # noqa: F401
    except ImportError:  # pragma: no cover - numba is pinned in requirements.txt
        return False
    return True


if enabled():
    import numba
    from numba.extending import register_jitable
    prange = numba.prange
    """numba.prange (parallel loop in a kernel built with parallel=True; range elsewhere)."""
else:
    numba = None
    register_jitable = None
    prange = range


class Kernels:
    """Namespace of built kernels: one attribute per kernel, and ``compiled``."""

    def __init__(self, functions: dict, compiled: bool):
        self.__dict__.update(functions)
        self.compiled = compiled
        self.names = tuple(functions)

    def __repr__(self) -> str:
        kind = 'compiled' if self.compiled else 'Python'
        return f'<{kind} kernels: {", ".join(self.names)}>'


class KernelSet:
    """The kernels of one module, and the numba options they are compiled with.

    ``options`` (e.g. ``error_model='numpy'``, ``nogil=True``) apply to every kernel, both
    when compiled into a compiled caller and as an entry point of ``JIT``.
    """

    def __init__(self, **options):
        self.options = options
        self._kernels = {}

    def __call__(self, func=None, /, inline: bool = False, **entry_options):
        """Mark ``func`` as a kernel (returned unchanged).

        ``entry_options`` are added to ``options`` only where ``func`` is compiled as an entry
        point of ``JIT`` (e.g. ``parallel=True``, ``fastmath=True``), not where it is compiled
        into a caller. ``inline``: a compiled caller gets ``func``'s statements in place of a
        call (numba's IR inlining; for thin kernels that pass named tuples of arrays on, whose
        calls would cost more than their work).
        """
        if func is None:
            return lambda f: self(f, inline=inline, **entry_options)
        if register_jitable is not None:
            register_jitable(inline='always' if inline else 'never', **self.options)(func)
        self._kernels[func.__name__] = (func, entry_options)
        return func

    def build(self) -> tuple[Kernels, Kernels]:
        """(JIT, PY): the kernels compiled with numba (lazily, cache=True), and as they are.

        Names are the functions' names. JIT is PY when
        compilation is off (:func:`enabled`).
        """
        py = Kernels({name: func for name, (func, _) in self._kernels.items()}, compiled=False)
        if numba is None:
            return py, py
        jit = Kernels({name: numba.njit(cache=True, **self.options, **entry)(func)
                       for name, (func, entry) in self._kernels.items()}, compiled=True)
        return jit, py
