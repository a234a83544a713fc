"""The user's code of a model of one's own, run behind a guard (brdf/own.py, docs/models.md).

Everything a model file runs -- its import, its ``evaluate``, its start rules -- runs
inside ``user_code``: what it prints goes to stderr (a command's stdout stays its own,
``--json`` one JSON document), ``sys.exit`` becomes an error instead of the end of the
command (``os._exit`` too, while the file is imported and checked: ``no_hard_exit``;
an import running past MAX_IMPORT_SECONDS is stopped: ``import_deadline``),
and any exception becomes one OwnModelError line naming the file, the model
and what was running (the parameter, for a start rule).

``check`` runs a declaration once when it is loaded, the way a fit will run it, so that
most mistakes are one line before any fit starts: at its defaults (eagerly), traced by
``jax.jit`` on another number of pairs (numpy on a traced array, a shape written into
the formula), differentiated by ``jax.grad``, the result's shape
and type (complex, integer), at each parameter's lower and upper bound (the others at
their defaults: a formula that is NaN or infinite somewhere in the box it is fitted in),
and each start rule on a mid-grey table's estimate (albedo and scale 0.5).
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys
import threading
import typing

if typing.TYPE_CHECKING:
    from .declare import Param

# A brdf.own.OwnModel (not imported, even for type checking: brdf.own imports this module)
OwnModelType = typing.Any

CHECK_PAIRS = 4                 # direction pairs the declaration's check evaluates (eagerly) ...
JIT_PAIRS = 7                   # ... and under jax.jit (another count: a shape written into the formula shows)
RECIPROCAL_RTOL = 1e-9          # f(wi, wo) and f(wo, wi) closer than this x max |f|: reciprocal (float64)
MAX_REASON = 200                # characters of a user's exception message in an error line
MAX_IMPORT_SECONDS = 60.0       # a model file's import that runs longer is stopped (a loop at import)


class OwnModelError(ValueError):
    """A model of one's own that cannot be used: one line, naming the file and what is wrong."""


def label(model: OwnModelType) -> str:
    """'FILE: own:NAME' (or 'own:NAME' for a model declared in Python) for a message."""
    where = f"{model.source[0]}: " if getattr(model, "source", None) else ""
    return f"{where}{model.model_string}"


def reason(err: BaseException) -> str:
    """An exception as 'Type: first line of its message' (shortened), with a hint for the
    mistakes JAX reports at length."""
    name = type(err).__name__
    lines = [line.strip() for line in str(err).strip().splitlines() if line.strip()]
    hint = ""
    if "Tracer" in name or "ConcretizationTypeError" in name:
        hint = " (use jax.numpy, not numpy or Python's if/float on the parameters and directions)"
    elif "Traceback (most recent call last)" in str(err):     # a callback's exception, inside XLA's error
        name, lines, hint = "", lines[-1:], " (in a JAX callback)"
    text = lines[0] if lines else ""
    text = text if len(text) <= MAX_REASON else text[:MAX_REASON - 3] + "..."
    return f"{name}: {text}{hint}" if name and text else f"{name or text}{hint}"


@contextlib.contextmanager
def user_code(where: str, what: str) -> typing.Iterator[None]:
    """Run the user's code: its prints on stderr, its ``sys.exit`` and its exceptions one
    OwnModelError '``where``: ``what`` ...' (an OwnModelError passes as it is)."""
    try:
        with held():
            yield
    except OwnModelError:
        raise
    except SystemExit as err:
        call = "os._exit" if isinstance(err, _HardExit) else "sys.exit"
        raise OwnModelError(f"{where}: {what} called {call}({err.code!r}); a model file must not end "
                            "the program") from None
    except Exception as err:  # noqa: BLE001 -- the user's code: one line, no traceback
        raise OwnModelError(f"{where}: {what} raised {reason(err)}") from None


class _TooLong(BaseException):
    """Raised in the main thread when a model file's import runs past ``MAX_IMPORT_SECONDS``
    (a BaseException: the user's ``except Exception`` does not swallow it)."""


@contextlib.contextmanager
def import_deadline(where: str) -> typing.Iterator[None]:
    """A model file's import that runs past MAX_IMPORT_SECONDS (a loop at import) is stopped:
    one OwnModelError line.  Main thread only, with SIGALRM free (elsewhere: no deadline)."""
    import signal
    usable = (threading.current_thread() is threading.main_thread() and hasattr(signal, "setitimer")
              and signal.getsignal(signal.SIGALRM) in (signal.SIG_DFL, None))

    def stop(signum, frame):
        raise _TooLong()
    if usable:
        signal.signal(signal.SIGALRM, stop)
        signal.setitimer(signal.ITIMER_REAL, MAX_IMPORT_SECONDS)
    try:
        yield
    except _TooLong:
        raise OwnModelError(f"{where}: importing it ran for more than {MAX_IMPORT_SECONDS:g} s (a loop at "
                            "import?); it was stopped") from None
    finally:
        if usable:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, signal.SIG_DFL)


class _HardExit(SystemExit):
    """``os._exit`` called by the user's code while ``no_hard_exit`` holds."""


@contextlib.contextmanager
def no_hard_exit() -> typing.Iterator[None]:
    """While a model file is imported and checked (in this thread): ``os._exit`` raises, so
    ``user_code`` makes it one line instead of the end of the process.  Other threads (the
    command line's Ctrl-C watchdog) still exit as they would."""
    real, me = os._exit, threading.get_ident()

    def refuse(code):
        if threading.get_ident() != me:
            real(code)
        raise _HardExit(code)
    os._exit = refuse
    try:
        yield
    finally:
        os._exit = real


_HELD_LOCK = threading.Lock()
_HELD = {"depth": 0, "stdout": None, "logger": None}
_CALLBACK_LOGGER = "jax._src.debugging"       # logs a jax.debug.callback's exception with its traceback


@contextlib.contextmanager
def held() -> typing.Iterator[None]:
    """While any thread runs the user's code: ``sys.stdout`` is ``sys.stderr`` (its prints
    never reach a command's stdout), and JAX's own report of an exception in a
    ``jax.debug.callback`` (a logged traceback) is left out (the exception becomes one line
    of ours).  Counted, so that the fits of two own models in two threads restore both
    once, in order (contextlib.redirect_stdout alone would not)."""
    import logging
    with _HELD_LOCK:
        if _HELD["depth"] == 0:
            logger = logging.getLogger(_CALLBACK_LOGGER)
            _HELD.update(stdout=sys.stdout, logger=logger.disabled)
            sys.stdout, logger.disabled = sys.stderr, True
        _HELD["depth"] += 1
    try:
        yield
    finally:
        with _HELD_LOCK:
            _HELD["depth"] -= 1
            if _HELD["depth"] == 0:
                sys.stdout = _HELD["stdout"]
                logging.getLogger(_CALLBACK_LOGGER).disabled = _HELD["logger"]
                _HELD.update(stdout=None, logger=None)


@contextlib.contextmanager
def running(model: OwnModelType, what: str, passing: tuple = ()) -> typing.Iterator[None]:
    """Toolkit code that runs a model of one's own (``model``; None: nothing to guard) beyond
    its tracing -- a fit, an evaluation -- where its jax.debug callbacks run: ``held``, and an
    exception it causes one OwnModelError '``FILE: own:NAME: WHAT failed: ...``' (OwnModelError,
    MemoryError and the ``passing`` types pass as they are)."""
    if model is None:
        yield
        return
    try:
        with held():
            yield
    except (OwnModelError, MemoryError, *passing):
        raise
    except Exception as err:  # noqa: BLE001 -- the user's code: one line, no traceback
        raise OwnModelError(f"{label(model)}: {what} failed: {reason(err)}") from None


def guarded_evaluate(where: str, evaluate: typing.Callable) -> typing.Callable:
    """``evaluate`` run inside ``user_code`` (while JAX traces it, and eagerly)."""
    @functools.wraps(evaluate)
    def run(params, wi, wo):
        with user_code(where, "evaluate"):
            return evaluate(params, wi, wo)
    return run


def guarded_rule(where: str, param: "Param", rule: typing.Callable) -> typing.Callable:
    """A start rule of ``param`` run inside ``user_code``, its value checked (finite, a
    number or ``param.size`` numbers) so that a bad start is a line naming the parameter."""
    import numpy as np
    what = f"the start rule of parameter {param.name!r}"

    @functools.wraps(rule)
    def run(estimate):
        with user_code(where, what):
            value = rule(estimate)
            out = np.asarray(value, dtype=np.float64)
        if out.size not in (1, param.size) or not np.all(np.isfinite(out)):
            raise OwnModelError(f"{where}: {what} returned {_shown(value)}; it must return "
                                f"{'a finite number' if param.size == 1 else '1 or 3 finite numbers'}")
        return float(out.ravel()[0]) if param.size == 1 else np.broadcast_to(out.ravel(), (3,)).copy()
    return run


def _shown(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def check(model: OwnModelType, evaluate: typing.Callable) -> bool:
    """OwnModelError unless ``evaluate`` (the guarded function of ``model``) runs at the
    defaults eagerly on CHECK_PAIRS direction pairs, under ``jax.jit`` (on JIT_PAIRS) and
    ``jax.grad``, and at each parameter's bounds, giving (pairs, 3) finite real values,
    and each start rule runs (the module's docstring).  Returns whether it is reciprocal
    there (each of those evaluations again with wi and wo swapped, to RECIPROCAL_RTOL),
    and refuses a model declared ``reciprocal=True`` that is not."""
    import jax
    import numpy as np

    from ._lazy import jnp
    where = label(model)
    with jax.enable_x64(True):      # as the fit runs it (fitting/_jax.py)
        wi, wo = _pairs(CHECK_PAIRS)
        wi_jit, wo_jit = _pairs(JIT_PAIRS)      # another count: a shape written into the formula shows

        def at(values):
            return {p.name: jnp.full((3,) if p.size == 3 else (), values.get(p.name, p.default), jnp.float64)
                    for p in model.params}
        defaults = at({})
        f = evaluate(defaults, wi, wo)
        _check_values(where, f, "at its defaults")
        jitted = jax.jit(evaluate)
        with user_code(where, "evaluate under jax.jit"):
            f = jitted(defaults, wi_jit, wo_jit)
            _check_values(where, f, "at its defaults", JIT_PAIRS)
        with user_code(where, "evaluate at its defaults with wi and wo swapped"):
            asymmetric = [("its defaults", _asymmetry(f, jitted(defaults, wo_jit, wi_jit)))]
        with user_code(where, "the gradient of evaluate (jax.grad)"):     # traced, not run (eagerly: 2 s)
            jax.eval_shape(jax.grad(lambda q: jnp.sum(evaluate(q, wi, wo))), defaults)
        estimate = _Estimate(np.full(3, 0.5), np.full(3, 0.5))      # a mid-grey table's, as starts.py forms it
        for p in model.params:
            if p.start.rule:
                guarded_rule(where, p, p.start.rule)(estimate)      # one line naming the parameter
            for bound, value in (("lower", p.lower), ("upper", p.upper)):
                at_bound = at({p.name: value})
                with user_code(where, f"evaluate at {p.name} = {value:g} (its {bound} bound)"):
                    f = jitted(at_bound, wi_jit, wo_jit)
                _check_values(where, f, f"at {p.name} = {value:g} (its {bound} bound; the other parameters at "
                                        "their defaults): narrow the bounds, or make the formula finite there",
                              JIT_PAIRS)
                with user_code(where, f"evaluate at {p.name} = {value:g} with wi and wo swapped"):
                    asymmetric.append((f"{p.name} = {value:g}", _asymmetry(f, jitted(at_bound, wo_jit, wi_jit))))
    worst = max(asymmetric, key=lambda a: a[1])
    if model.reciprocal is True and worst[1] > RECIPROCAL_RTOL:
        raise OwnModelError(f"{where}: declared reciprocal=True, but f(wi, wo) and f(wo, wi) differ by "
                            f"{worst[1]:.3g} (relative) at {worst[0]}: leave reciprocal out (the toolkit "
                            "finds it) or make the formula symmetric")
    return worst[1] <= RECIPROCAL_RTOL


def _asymmetry(f, f_swapped) -> float:
    """max |f(wi, wo) - f(wo, wi)| / max |f| (0 where f is 0 everywhere)."""
    import numpy as np
    f, f_swapped = np.asarray(f), np.asarray(f_swapped)
    scale = np.max(np.abs(f))
    return float(np.max(np.abs(f - f_swapped)) / scale) if scale > 0 else 0.0


def _pairs(n: int):
    """``n`` direction pairs (wi, wo) in the plane of incidence, theta from 0.1 to 1.2 rad."""
    import numpy as np

    from ._lazy import jnp
    theta = np.linspace(0.1, 1.2, n)
    wi = np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], -1)
    wo = np.stack([-np.sin(theta[::-1]), np.zeros_like(theta), np.cos(theta[::-1])], -1)
    return jnp.asarray(wi), jnp.asarray(wo)


class _Estimate(typing.NamedTuple):
    """What a start rule reads (fitting.starts.Estimate: albedo and scale, RGB in [0, 1])."""
    albedo: typing.Any
    scale: typing.Any


def _check_values(where: str, f, at: str, pairs: int = CHECK_PAIRS) -> None:
    import numpy as np
    f = f if hasattr(f, "shape") and hasattr(f, "dtype") else np.asarray(f)
    shape, dtype = f.shape, f.dtype
    if shape != (pairs, 3):
        raise OwnModelError(f"{where}: evaluate returned shape {shape} for {pairs} direction pairs; "
                            f"it must return ({pairs}, 3) (RGB per pair)")
    if np.issubdtype(dtype, np.complexfloating):
        raise OwnModelError(f"{where}: evaluate returned complex values ({dtype}); a BRDF is real: "
                            "take the real part or the modulus in the formula")
    if not np.issubdtype(dtype, np.floating):
        raise OwnModelError(f"{where}: evaluate returned {dtype} values; a BRDF is real, with a gradient: "
                            "return floating-point values (integers cannot be fitted)")
    values = np.asarray(f)
    if not np.all(np.isfinite(values)):
        kind = "NaN" if np.any(np.isnan(values)) else "infinite"
        raise OwnModelError(f"{where}: evaluate is {kind} {at}")
