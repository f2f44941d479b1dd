"""Compiled time loops that a short command does not pay to compile.

Layer 1 of the planner. A loop whose step depends on the step before (the circuit's
state, a Newton iteration per element, the running stress of the integral model) cannot
be vectorised with numpy; it is compiled with numba. But numba's first call in a process
costs about 0.3 s of CPU even when the machine code comes from its on-disk cache (it
initialises the compiler's type and lowering registries, measured by
``benchmarks/bench_startup.py``), while ``endurance check`` on a survey runs a few
thousand steps in all, which the interpreter does in a few hundredths of a second.

:func:`kernel` declares such a loop once, as numba source. A process runs its first
:data:`INTERPRETED_ELEMENTS` elements (summed over every kernel's calls; an element is
one entry of the largest array a call is given: a time step, a pack at a leg, a root)
through the same source interpreted, with the compiled twins of the elements it calls
replaced by their Python source too; from the call that would exceed it on, every
kernel runs compiled. So a long series is never looped over in Python, and the answers
are those of one source: the interpreted and compiled runs agree to rounding
(``tests/physics/test_kernel.py``). A process that runs long and must answer each
update fast (``endurance watch``) compiles from its first call instead
(:func:`compile_from_start`). Under ``NUMBA_DISABLE_JIT=1`` numba's own dispatchers are
the Python functions, so every call is interpreted either way.
"""

from __future__ import annotations

import functools
import types

import numba
import numpy as np
from numba.core.dispatcher import Dispatcher

__all__ = ["INTERPRETED_ELEMENTS", "Kernel", "compile_from_start", "kernel"]

#: Elements a process runs interpreted before its kernels run compiled. At about
#: 15 µs per element in the slowest kernel interpreted (the rotor inflow's Newton
#: iteration; the circuit's step costs about 3 µs), 20 000 elements cost about as much
#: CPU as numba's start-up (0.29 s). [elements]
INTERPRETED_ELEMENTS = 20_000


class Kernel:
    """A compiled loop that runs interpreted while the process's interpreted budget lasts
    (module notes). Called as the function it wraps; ``compiled`` is the numba dispatcher
    and ``interpreted`` the same source with every compiled function it calls replaced
    by its Python source."""

    #: Elements run interpreted so far in this process (all kernels). [elements]
    spent = 0
    #: Whether a kernel has run compiled in this process (numba has started). [bool]
    started = False

    def __init__(self, formula, **options):
        functools.update_wrapper(self, formula)
        self.compiled = numba.njit(cache=True, **options)(formula)

    @functools.cached_property
    def interpreted(self):
        """The source with the compiled functions it reaches replaced by their Python
        source (:func:`_twin`), under numpy's floating-point rules without warnings."""
        fn = _twin(self.compiled)

        def run(*args, **kwargs):
            with np.errstate(all="ignore"):
                return fn(*args, **kwargs)
        return run

    def __call__(self, *args, **kwargs):
        if not Kernel.started:
            size = max((a.size for a in (*args, *kwargs.values())
                        if isinstance(a, np.ndarray)), default=1)
            if Kernel.spent + size <= INTERPRETED_ELEMENTS:
                Kernel.spent += size
                return self.interpreted(*args, **kwargs)
            Kernel.started = True
        return self.compiled(*args, **kwargs)


def kernel(formula=None, **options):
    """Declare a compiled loop (:class:`Kernel`); ``options`` go to ``numba.njit`` (which
    always caches on disk). Used bare (``@kernel``) or with options
    (``@kernel(error_model="numpy")``). A kernel is called from Python only: a compiled
    function that another compiled function calls stays a numba dispatcher (numba inlines
    it)."""
    if formula is None:
        return lambda f: Kernel(f, **options)
    return Kernel(formula, **options)


def compile_from_start() -> None:
    """Run every kernel compiled from now on in this process: for a process that runs long
    and must answer each update fast (``endurance watch``), not start fast; it pays
    numba's start-up at its first call instead of interpreting its early updates."""
    Kernel.started = True


#: The interpreted twins made so far, by the id of what they stand for (compiled functions
#: and the planner's modules that hold some; both live as long as the process).
_TWINS: dict[int, object] = {}


def _twin(compiled):
    """The interpreted twin of a numba dispatcher: its Python source with its globals'
    compiled functions, and the modules holding any, replaced by their twins (made once;
    registered before its globals are filled, so that functions that reach each other
    share their twins); a plain function (``NUMBA_DISABLE_JIT``) as it is."""
    if not isinstance(compiled, Dispatcher):
        return compiled
    if id(compiled) in _TWINS:
        return _TWINS[id(compiled)]
    fn = compiled.py_func
    glob: dict = {}
    _TWINS[id(compiled)] = twin = types.FunctionType(
        fn.__code__, glob, fn.__name__, fn.__defaults__, fn.__closure__)
    glob.update({k: _global_twin(v) for k, v in fn.__globals__.items()})
    return twin


def _global_twin(value):
    """A global a kernel's source reads, for its interpreted twin: a compiled function's
    twin, a module of the planner that holds compiled functions as a namespace of twins,
    anything else as it is."""
    if isinstance(value, Dispatcher):
        return _twin(value)
    if isinstance(value, types.ModuleType) and value.__name__.startswith("planner."):
        if id(value) in _TWINS:
            return _TWINS[id(value)]
        members = dict(vars(value))
        if any(isinstance(v, Dispatcher) for v in members.values()):
            _TWINS[id(value)] = space = types.SimpleNamespace()
            for k, v in members.items():
                setattr(space, k, _twin(v))
            return space
    return value
