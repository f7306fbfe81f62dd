"""The ``auvdock`` command line (Typer + rich): one module per command group.

Exit status: 0 success; 1 a run finished but did not dock / a command failed at run
time; 2 bad input (a mission file, an option) -- with ONE line on stderr naming the
file, the field and the problem, and no traceback; 130 interrupted (Ctrl-C).

=================  ==============================================
module             commands
=================  ==============================================
``app``            the Typer app, console, one-line input errors
``validate``       validate
``sim``            sim, plot
``campaign``       compare, report, sweep
``fly``            fly, vehicle-sim, replay, truth-check
``sitl``           sitl-physics
``bench``          bench
``camera``         markers, calibrate
``bem``            dock-table
``cache``          cache info, cache clear
=================  ==============================================
"""

from __future__ import annotations

import re
import signal
import sys
import threading

# the commands are registered in this order (the order of --help); a Ctrl-C while they load is the
# console script's to handle (auvdock.__main__), not this package's: a library user who imports it
# keeps Python's own KeyboardInterrupt
# isort: off
from auvdock.cli import validate, sim, campaign, fly, sitl, bench, camera, bem, cache  # noqa: F401, E402

# isort: on
try:  # typer vendors click since 0.2x; older ones use click itself
    from typer._click import exceptions as _cx  # noqa: E402
except ImportError:  # pragma: no cover
    from click import exceptions as _cx  # type: ignore[no-redef]  # noqa: E402

from auvdock.cli.app import app, err_console, interrupt_reported  # noqa: E402
from auvdock.runtime.interrupts import interrupt_name, sigterm_interrupts  # noqa: E402

__all__ = ["app", "main"]


def main(argv: list[str] | None = None) -> None:
    """Run a command and exit with its status (the console script's entry, :func:`auvdock.__main__.main`,
    loads the commands and calls this).

    0 success; 1 a run that did not dock or a command that failed at run time; 2 bad input
    (one line on stderr: ``error: ...``); 130 interrupted (Ctrl-C), with no traceback.
    """
    import typer

    _sigint_stops()
    sigterm_interrupts()
    try:
        rc = app(args=argv, standalone_mode=False)
    except _cx.NoArgsIsHelpError as e:
        print(e.ctx.get_help() if e.ctx is not None else str(e))
        rc = 0
    except _cx.UsageError as e:  # a bad option or argument: one line, exit 2
        _one_line(_usage_line(e, sys.argv[1:] if argv is None else list(argv)))
        rc = 2
    except _cx.ClickException as e:
        _one_line(f"error: {e.format_message()}")
        rc = e.exit_code
    except (typer.Abort, KeyboardInterrupt):
        rc = 130
    if rc == 130 and not interrupt_reported():  # Typer turns Ctrl-C into exit 130, silently
        said = "interrupted" if interrupt_name() == "Ctrl-C" else f"interrupted ({interrupt_name()})"
        err_console.print(said, markup=False, highlight=False)
    _ignore_late_sigint()
    sys.exit(rc if isinstance(rc, int) else 0)


def _sigint_stops() -> None:
    """Ctrl-C (SIGINT) stops every command, even one started with SIGINT ignored: a background job
    of a non-interactive shell (``auvdock compare ... &`` in a script) inherits SIG_IGN, and Python
    then installs no handler of its own, so the command could not be interrupted at all.  The
    default handler (KeyboardInterrupt) is put back; the commands' own Ctrl-C handling (results
    kept, worker processes stopped, exit 130) does the rest.  SIGTERM is made a Ctrl-C
    (:func:`auvdock.runtime.interrupts.sigterm_interrupts`)."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.default_int_handler)


def _ignore_late_sigint() -> None:
    """The command has ended and said so: a Ctrl-C now (exiting) changes nothing and prints nothing."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def _one_line(text: str) -> None:
    err_console.print(" ".join(text.split()), markup=False, highlight=False, soft_wrap=True)


def _usage_line(e: Exception, args: list[str] | None = None) -> str:
    """``error: --seed: expected a whole number (got 'abc')`` from a usage error: the option (as
    typed in ``args``, else its first long name) or argument, then the problem in plain words --
    the one format of every option error, whatever raised it (click, typer's pydantic coercion,
    a callback)."""
    param = getattr(e, "param", None)
    if isinstance(e, _cx.NoSuchOption):
        near = sorted(e.possibilities or ())
        hint = f" (did you mean {' or '.join(near)}?)" if near else ""
        return f"error: {e.option_name}: no such option{hint}"
    if isinstance(e, _cx.BadOptionUsage):
        return f"error: {e.option_name}: {_option_usage(e.message, e.option_name)}"
    if isinstance(e, _cx.MissingParameter):
        return f"error: {_param_hint(param, args)}: required, not given"
    if isinstance(e, _cx.BadParameter):
        return f"error: {_param_hint(param, args)}: {_plain_problem(e)}"
    message = getattr(e, "message", None) or str(e)
    extra = re.match(r"Got unexpected extra argument(?:\(s\)|s)? \((.*)\)$", message)
    if extra:
        many = "s" if " " in extra.group(1).strip() else ""
        return f"error: {extra.group(1)}: unexpected argument{many} (no more arguments are taken)"
    return f"error: {_sentence(message)}"


def _param_hint(param, args: list[str] | None) -> str:  # noqa: ANN001 -- a click Parameter or None
    """The option as the user typed it (``--workers`` rather than ``--jobs``), else its first long
    name; an argument in capitals (``MISSION``)."""
    if param is None:
        return "?"
    if getattr(param, "param_type_name", "") == "argument":
        return str(param.name).upper()
    names = [n for n in [*getattr(param, "opts", []), *getattr(param, "secondary_opts", [])] if n]
    for a in args or []:
        for n in names:
            if a == n or a.startswith(f"{n}=") or (not n.startswith("--") and a.startswith(n) and len(a) > 2):
                return n
    longs = [n for n in names if n.startswith("--")]
    return (longs or names or [str(param.name)])[0]


def _show(value) -> str:  # noqa: ANN001
    """A value as typed: a number bare (``0``, ``1.5``), anything else quoted (``'abc'``)."""
    if isinstance(value, str):
        try:
            float(value)
        except ValueError:
            return repr(value)
    return str(value)


#: pydantic error types (typer's coercion of option values) -> the problem in plain words.
_PLAIN = {
    "int_parsing": "expected a whole number (got {input})",
    "int_type": "expected a whole number (got {input})",
    "int_from_float": "expected a whole number (got {input})",
    "float_parsing": "expected a number (got {input})",
    "float_type": "expected a number (got {input})",
    "bool_parsing": "expected true or false (got {input})",
    "greater_than_equal": "must be at least {ge} (got {input})",
    "greater_than": "must be more than {gt} (got {input})",
    "less_than_equal": "must be at most {le} (got {input})",
    "less_than": "must be less than {lt} (got {input})",
    "finite_number": "must be a finite number (got {input})",
    "literal_error": "must be {expected} (got {input})",
    "enum": "must be {expected} (got {input})",
}


def _plain_problem(e: Exception) -> str:
    """A bad parameter's problem in plain words, e.g. ``must be at least 1 (got 0)``."""
    cause = e.__cause__
    errors = getattr(cause, "errors", None)
    if callable(errors):
        try:
            first = errors()[0]
        except (IndexError, TypeError):
            first = None
        if first is not None:
            words = {k: _show(v) if k == "input" else v for k, v in (first.get("ctx") or {}).items()}
            words["input"] = _show(first.get("input"))
            template = _PLAIN.get(str(first.get("type")))
            if template is not None:
                try:
                    return template.format(**words)
                except (KeyError, IndexError):
                    pass
            return f"{_sentence(str(first.get('msg', '')))} (got {words['input']})"
    return _sentence(str(getattr(e, "message", "") or e))


def _option_usage(message: str, option: str) -> str:
    """click's option misuse (``Option '--seed' requires an argument.``) in plain words."""
    if "requires" in message:
        return "needs a value"
    if "does not take a value" in message:
        return "takes no value"
    return _sentence(message.replace(f"Option {option!r} ", ""))


def _sentence(text: str) -> str:
    """``Input should be ...`` -> ``input should be ...``: lower-case start, no full stop."""
    text = " ".join(str(text).split()).rstrip(".")
    return text[:1].lower() + text[1:] if text[:2] != text[:2].upper() else text


if __name__ == "__main__":  # pragma: no cover
    main()
