"""Process supervision every firmware bridge shares: free ports, an instance number reserved under a
lock file, and the firmware process itself (:class:`FirmwareProcess`: its own process group and
working directory, its output in a log file, its whole group killed with the process that started it
(:class:`vinecli.lifeline.GroupLifeline`: also what a wrapper script started without ``exec``), the group
stopped SIGTERM-then-SIGKILL, its files kept before the working directory goes). A working directory vinecli
makes is a scratch folder named after its owner (:mod:`vinecli.scratch`), swept by the next vinecli if a
``kill -9`` left it.

An instance number is reserved with an exclusive lock file (``$TMPDIR/vinecli-<firmware>/instance-N.lock``)
held for the life of the run, and only taken when the firmware's ports for it are free, so parallel
batch workers (``run batch --workers 2``) never share an instance.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from pathlib import Path

from vinecli.errors import AutopilotError, InputError
from vinecli.lifeline import GroupLifeline, die_with_parent, group_alive
from vinecli.locks import try_lock, unlock
from vinecli.scratch import scratch_dir

AUTO_INSTANCES = range(10, 100)  # 0..9 are left to people running a firmware by hand


def port_free(port: int, kind: int, host: str = "127.0.0.1") -> tuple[bool, str]:
    """Can vinecli bind ``port`` now (and if not, the OS's reason)? TCP with SO_REUSEADDR, as vinecli's
    server binds: a connection of the last run in TIME_WAIT does not count, a listener does. UDP without
    it (it would share a port)."""
    s = socket.socket(socket.AF_INET, kind)
    if kind == socket.SOCK_STREAM:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        s.bind((host, port))
    except OSError as exc:
        return False, exc.strerror or str(exc)
    finally:
        s.close()
    return True, ""


class InstanceLock:
    """An exclusive claim on one firmware instance number (released by :meth:`release`, which removes its lock file
    and, when it was the last, the folder of them: nothing is left in the temporary directory)."""

    def __init__(self, instance: int, path: Path, fd: int) -> None:
        self.instance = instance
        self.path = path
        self._fd: int | None = fd

    def release(self) -> None:
        """Drop the lock. Idempotent."""
        if self._fd is not None:
            unlock(self.path, self._fd)
            self._fd = None
            with contextlib.suppress(OSError):
                self.path.parent.rmdir()  # only when empty: another run's lock keeps it


def reserve_instance(firmware: str, ports_free: Callable[[int], bool],
                     candidates: range | list[int] = AUTO_INSTANCES) -> InstanceLock:
    """Lock the first instance of ``firmware`` whose lock file is free and for which ``ports_free(i)``."""
    lock_dir = Path(tempfile.gettempdir()) / f"vinecli-{firmware.lower()}"
    for i in candidates:
        path = lock_dir / f"instance-{i}.lock"
        for _ in range(10):  # another run may remove the folder, emptied, between our mkdir and open
            lock_dir.mkdir(exist_ok=True)
            try:
                fd = try_lock(path)
                break
            except FileNotFoundError:
                continue
        else:
            raise AutopilotError(f"cannot make the instance lock {path}")
        if fd is None:
            continue
        if ports_free(i):
            return InstanceLock(i, path, fd)
        unlock(path, fd)
    raise AutopilotError(f"no free {firmware} instance in {candidates[0]}..{candidates[-1]} "
                         "(all locked or ports in use)")


class FirmwareProcess(ABC):
    """One firmware SITL process: :meth:`start`, :meth:`alive`, :meth:`log_tail`, :meth:`stop`, :meth:`keep`.

    Subclasses give :meth:`command` (argv), and may add to :meth:`environment` and :meth:`prepare` (files
    the firmware reads at start). ``workdir`` None: a fresh temporary directory, deleted by :meth:`stop`
    (:meth:`discard`, after :meth:`keep` copied out what the run keeps)."""

    firmware = "firmware"
    option = "--firmware-bin"  # the command-line option naming the binary (error messages)
    log_name = "firmware.log"

    def __init__(self, binary: str | Path, instance: int, *, workdir: str | Path | None = None) -> None:
        self.bin = Path(binary).expanduser()
        if not self.bin.is_file() or not os.access(self.bin, os.X_OK):
            raise InputError(f"{self.option} {binary}: not an executable file")
        self.check()  # before anything is created: a refused binary leaves no folder
        self.instance = instance
        self._own_dir = workdir is None
        self.workdir = Path(workdir) if workdir is not None else scratch_dir(self.firmware.lower())
        self.log_path = self.workdir / self.log_name
        self.proc: subprocess.Popen[bytes] | None = None
        self.returncode: int | None = None
        self._log_text = ""
        self._lifeline: GroupLifeline | None = None

    def check(self) -> None:  # noqa: B027 - a hook: most firmwares need nothing beside the binary
        """Refuse (InputError) a binary that cannot run here, before anything is created."""

    @abstractmethod
    def command(self) -> list[str]:
        """argv of the firmware process."""

    @property
    def cwd(self) -> Path:
        """The directory the firmware runs in."""
        return self.workdir

    def environment(self) -> dict[str, str]:
        return dict(os.environ)

    def prepare(self) -> None:  # noqa: B027 - a hook: most firmwares read nothing vinecli writes
        """Write what the firmware reads at start (called by :meth:`start`, after the directory exists)."""

    def start(self) -> None:
        """Start the firmware in its own process group, its output into :attr:`log_path`."""
        self.cwd.mkdir(parents=True, exist_ok=True)
        self.prepare()
        with self.log_path.open("wb") as log:
            try:
                self.proc = subprocess.Popen(self.command(), cwd=self.cwd, env=self.environment(), stdin=subprocess.DEVNULL,
                                             stdout=log, stderr=subprocess.STDOUT, start_new_session=True,
                                             preexec_fn=die_with_parent if os.name == "posix" else None)
            except OSError as exc:
                raise AutopilotError(f"cannot start {self.firmware} {self.bin}: {exc.strerror or exc}") from None
        self._lifeline = GroupLifeline(self.proc.pid)  # its own group: the wrapper's children too
    @property
    def pid(self) -> int | None:
        return self.proc.pid if self.proc is not None else None

    def alive(self) -> bool:
        """True while the process runs."""
        return self.proc is not None and self.proc.poll() is None

    def log_tail(self, lines: int = 12) -> str:
        """The last lines the firmware printed (for error messages)."""
        text = self._log_text
        if not text and self.log_path.is_file():
            text = self.log_path.read_text(errors="replace")
        return "\n".join(text.splitlines()[-lines:])

    def log_note(self, lines: int = 8) -> str:
        """``"; <firmware> log (<path>) ends: a | b | c"`` for an error message ('' when it printed nothing); a
        temporary working directory is removed at the end, so the path named is the run folder's kept copy."""
        tail = self.log_tail(lines).strip()
        where = f"firmware/{self.log_name} in the run folder" if self._own_dir else str(self.log_path)
        return f"; {self.firmware} log ({where}) ends: " + " | ".join(tail.splitlines()) if tail else ""

    def stop(self, timeout_s: float = 5.0, while_waiting: Callable[[], None] | None = None) -> int | None:
        """SIGTERM the process group, SIGKILL after ``timeout_s``; ``while_waiting()`` is called in the
        wait (a lockstep firmware exits only once its clock moves again). The whole group, not only the process
        vinecli started: a wrapper script that exits leaves its firmware behind in it. Idempotent."""
        p = self.proc
        if p is not None and self.returncode is None:
            for sig, wait in ((signal.SIGTERM, timeout_s), (signal.SIGKILL, 5.0)):
                p.poll()  # reap the group leader, or it counts as alive
                if not group_alive(p.pid):
                    break
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(p.pid, sig)
                deadline = time.monotonic() + wait
                while time.monotonic() < deadline:
                    p.poll()
                    if not group_alive(p.pid):
                        break
                    if while_waiting is not None and sig == signal.SIGTERM:
                        while_waiting()
                    else:
                        time.sleep(0.02)
            self.returncode = p.poll()
        if self._lifeline is not None:
            self._lifeline.dismiss()
            self._lifeline = None
        if self.log_path.is_file():
            self._log_text = self.log_path.read_text(errors="replace")
        return self.returncode

    def keep(self, patterns: tuple[str, ...], dest: Path) -> list[Path]:
        """Copy the files of the working directory matching ``patterns`` (globs) into ``dest``; their new paths."""
        dest.mkdir(parents=True, exist_ok=True)
        kept = []
        for pattern in patterns:
            for f in sorted(self.workdir.glob(pattern)):
                if f.is_file():
                    target = dest / f.name
                    shutil.copy2(f, target)
                    kept.append(target)
        return kept

    def discard(self) -> None:
        """Remove a temporary working directory (one given by the caller stays)."""
        if self._own_dir and self.workdir.exists():
            shutil.rmtree(self.workdir, ignore_errors=True)


__all__ = ["AUTO_INSTANCES", "FirmwareProcess", "InstanceLock", "die_with_parent", "port_free", "reserve_instance"]
