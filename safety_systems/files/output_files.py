"""Every file the project writes: the output folder checked before any work, and each
result written atomically (to a temporary file beside it, then renamed over it), so an
interrupted run leaves the old file or the new one, never half of one."""

import contextlib
import json
import os
import tempfile
import typing
import uuid
from pathlib import Path

from safety_systems.files.input_error import InputError


def prepare_out(path: str | Path, option: str = "--out") -> Path:
    """Creates the output folder ``path`` (and its parents) and checks that a file can
    be written in it; raises InputError naming ``option`` otherwise. Temporary files
    that a killed run left in it are removed."""
    path = Path(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=path):
            pass
        for part in path.glob(".*.part"):
            _remove_if_stale(part)
    except OSError as e:
        reason = e.strerror or type(e).__name__
        if isinstance(e, FileExistsError) or (path.exists() and not path.is_dir()):
            reason = "a file of that name is in the way"
        raise InputError(option, str(path), f"a folder that can be created and written "
                                            f"({reason})") from None
    return path


def _temporary_name(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.part")


def _remove_if_stale(part: Path) -> None:
    """Removes a temporary file of :func:`atomic_path` whose process has ended."""
    try:
        pid = int(part.name.rsplit(".", 3)[-3])
    except (ValueError, IndexError):
        return
    if pid <= 0:
        return
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        part.unlink(missing_ok=True)
    except OSError:
        pass  # alive, or not ours to ask about


@contextlib.contextmanager
def atomic_path(path: str | Path) -> typing.Iterator[Path]:
    """A temporary path beside ``path`` to write to (``.NAME.PID.RANDOM.part``); renamed
    over ``path`` when the block ends without an exception, removed otherwise."""
    path = Path(path)
    temporary = _temporary_name(path)
    temporary.touch(exist_ok=False)  # with the permissions the umask gives a new file
    try:
        yield temporary
        with open(temporary, "rb+") as f:
            os.fsync(f.fileno())
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


def write_text(path: str | Path, text: str) -> None:
    """Writes ``text`` to ``path`` atomically."""
    with atomic_path(path) as temporary:
        temporary.write_text(text)


def write_json(path: str | Path, data: typing.Any) -> None:
    """Writes ``data`` as indented JSON (and a final newline) to ``path`` atomically."""
    write_text(path, json.dumps(data, indent=2) + "\n")


def save_figure(figure, path: str | Path, **kwargs) -> None:
    """``figure.savefig`` to ``path`` atomically (the format from ``path``'s suffix)."""
    with atomic_path(path) as temporary:
        figure.savefig(temporary, format=Path(path).suffix.lstrip(".") or None, **kwargs)
