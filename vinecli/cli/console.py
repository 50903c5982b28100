"""The one place that maps errors to exit codes and renders them.

Commands are wrapped with :func:`handles_errors`: a :class:`~vinecli.errors.VinecliError`
becomes one red line on stderr (``vinecli: error: FILE: problem``) and its exit code;
anything unexpected becomes one line and exit 3. ``vinecli --debug`` re-raises so the
traceback is shown.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import signal
import sys
import warnings
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Any, TypeVar

import typer
from rich.console import Console, ConsoleOptions, ConsoleRenderable, RenderHook
from rich.segment import Segment
from rich.table import Table
from rich.text import Text

from vinecli.errors import VinecliError
from vinecli.stop_signals import signal_name

if TYPE_CHECKING:
    from rich.progress import Progress


class _ShowControls(RenderHook):
    """Every renderable printed is rendered with the control characters of its text shown as ``\\xNN``: a
    terminal escape in a check name, a case name or a file's metadata never reaches the terminal. Rich's own
    styles and cursor moves are separate (style and control segments) and pass unchanged."""

    def process_renderables(self, renderables: list[ConsoleRenderable]) -> list[ConsoleRenderable]:
        return [_Escaped(r) for r in renderables]


class _Escaped:
    def __init__(self, renderable: ConsoleRenderable) -> None:
        self.renderable = renderable

    def __rich_console__(self, console: Console, options: ConsoleOptions) -> Iterator[Segment]:
        from vinecli.report.text import printable

        for seg in console.render(self.renderable, options):
            yield seg if seg.control else Segment(printable(seg.text), seg.style)


err_console = Console(stderr=True, highlight=False, soft_wrap=True)
out_console = Console(highlight=False, soft_wrap=True)
for _c in (err_console, out_console):
    _c.push_render_hook(_ShowControls())


class PlainTable(Table):
    """A table whose string cells are shown as written (no Rich markup: text from files and names stays text)."""

    def add_row(self, *renderables: Any, **kwargs: Any) -> None:  # type: ignore[override]
        super().add_row(*(Text(r) if isinstance(r, str) else r for r in renderables), **kwargs)

F = TypeVar("F", bound=Callable[..., Any])


class _State:
    debug: bool = False


STATE = _State()


class _RichLogHandler(logging.Handler):
    """Rich's log handler, made at the first record that reaches it (``rich.logging`` loads Rich's traceback
    and syntax machinery: a command that logs nothing does not pay for it)."""

    def __init__(self) -> None:
        super().__init__()
        self._rich: logging.Handler | None = None

    def emit(self, record: logging.LogRecord) -> None:
        if self._rich is None:
            from rich.logging import RichHandler

            self._rich = RichHandler(console=err_console, show_time=False, show_path=False, markup=False)
        self._rich.handle(record)


class HeldWarnings(logging.Handler):
    """Warnings wait for the command's ending (:meth:`hold`): shown when it succeeds or fails at run time
    (:meth:`show_held`), dropped when it refuses bad input (:meth:`drop_held`), whose one error line says it all.
    Records below WARNING, and those logged with ``extra={"at_once": True}`` (the answer to a stop signal), pass at
    once."""

    def __init__(self, target: logging.Handler) -> None:
        super().__init__()
        self.target = target
        self.held: list[logging.LogRecord] | None = None

    def emit(self, record: logging.LogRecord) -> None:
        if self.held is not None and record.levelno >= logging.WARNING and not getattr(record, "at_once", False):
            self.held.append(record)
        else:
            self.target.handle(record)

    def hold(self) -> None:
        self.held = []

    def show_held(self) -> None:
        held, self.held = self.held or [], None
        for record in held:
            self.target.handle(record)

    def drop_held(self) -> None:
        self.held = None


HELD = HeldWarnings(_RichLogHandler())


def setup_logging(verbosity: int, debug: bool) -> None:
    """Route stdlib logging to Rich on stderr; WARNING by default, -v INFO, -vv DEBUG. Warnings wait for the
    command's ending (:class:`HeldWarnings`); other libraries' log records and Python warnings (shapely's
    RuntimeWarning, GDAL's notes) show from -vv only, as DEBUG lines."""
    STATE.debug = debug
    level = logging.DEBUG if (debug or verbosity >= 2) else logging.INFO if verbosity == 1 else logging.WARNING
    root = logging.getLogger("vinecli")
    root.handlers.clear()
    root.addHandler(HELD)
    root.setLevel(level)
    root.propagate = False
    others = logging.getLogger()
    others.handlers.clear()
    others.addHandler(_Demoted(HELD) if level <= logging.DEBUG else logging.NullHandler())


class _Demoted(logging.Handler):
    """Another library's record (or a Python warning, through ``py.warnings``) as a DEBUG line."""

    def __init__(self, target: logging.Handler) -> None:
        super().__init__()
        self.target = target

    def emit(self, record: logging.LogRecord) -> None:
        record.levelno, record.levelname = logging.DEBUG, "DEBUG"
        self.target.handle(record)


def error_line(message: str) -> None:
    """Print one error line on stderr."""
    err_console.print(f"[bold red]vinecli: error:[/] {message}", markup=True, highlight=False)


def handles_errors(fn: F) -> F:
    """Decorator for Typer commands: map errors to one stderr line and an exit code; warnings are shown when
    the command ends, except after bad input (:class:`HeldWarnings`)."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        from vinecli.inputs import reading_inputs

        HELD.hold()
        bad_input = False
        try:
            with reading_inputs(), _warnings_logged():  # every file read is an input its outputs may not touch
                return fn(*args, **kwargs)
        except typer.Exit:
            raise
        except VinecliError as exc:
            bad_input = exc.exit_code == 2  # its one line says it all
            if STATE.debug:
                raise
            _flush(bad_input)
            error_line(_escape(str(exc)))
            raise typer.Exit(exc.exit_code) from None
        except KeyboardInterrupt as exc:  # Ctrl-C, or a stop signal that aborts (vinecli.stop_signals.Aborted)
            _flush(False)
            signum = int(getattr(exc, "signum", signal.SIGINT))
            how = "a second " if getattr(exc, "second", False) else ""
            error_line(f"stopped at once by {how}{signal_name(signum)} (nothing half-written is left)")
            raise typer.Exit(128 + signum) from None
        except Exception as exc:  # noqa: BLE001 - the one catch-all, by design
            if STATE.debug:
                raise
            _flush(False)
            error_line(_escape(f"internal error: {type(exc).__name__}: {exc} (run with --debug for the traceback)"))
            raise typer.Exit(3) from None
        finally:
            _flush(bad_input)

    return wrapper  # type: ignore[return-value]


def _flush(drop: bool) -> None:
    HELD.drop_held() if drop else HELD.show_held()


@contextlib.contextmanager
def _warnings_logged() -> Iterator[None]:
    """Python warnings (shapely's RuntimeWarning on NaN coordinates...) go to logging (``py.warnings``: shown
    from -vv), never straight to stderr."""
    with warnings.catch_warnings():
        warnings.simplefilter("default")
        logging.captureWarnings(True)
        try:
            yield
        finally:
            logging.captureWarnings(False)


def _escape(text: str) -> str:
    """Escape Rich markup, show control characters as ``\\xNN`` (a terminal escape in a name or a file's
    text must not reach the terminal) and fold to one line."""
    return safe(" ".join(str(text).split()))


def safe(text: Any) -> str:
    """User text (names, messages, anything read from a file) for a Rich console: control characters shown
    as ``\\xNN`` escapes, Rich markup escaped."""
    from rich.markup import escape

    from vinecli.report.text import printable

    return escape(printable(text))


def progress(*, transient: bool | None = None) -> Progress:
    """A Rich progress bar of items done (n/total) on stderr, hidden when stderr is not a terminal and not forced.
    ``transient``: remove the bar when done (default: when stderr is not a tty)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(
        TextColumn("[progress.description]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TextColumn("{task.fields[info]}"),
        console=err_console,
        transient=not sys.stderr.isatty() if transient is None else transient,
        disable=not err_console.is_terminal,
    )


def sim_progress() -> Progress:
    """A Rich progress bar of simulated time (its ``info`` field shows sim time and speed) on stderr; removed
    when done, hidden when stderr is not a terminal and not forced."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(
        TextColumn("[progress.description]{task.description}"),
        BarColumn(),
        TextColumn("{task.fields[info]}"),
        TimeElapsedColumn(),
        console=err_console,
        transient=True,
        disable=not err_console.is_terminal,
    )
