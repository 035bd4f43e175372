"""The one kind of error for bad input: a file's field or a command-line option, in one
line naming the file (when there is one), the field, the value (shortened) and what is
allowed. The CLI prints it and exits with code 2."""

import reprlib
import typing
from pathlib import Path


class InputError(ValueError):
    """A bad input (a file's field, or a command-line option): one line naming the file
    (when there is one), the field, the value (shortened) and what is allowed."""

    def __init__(self, field: str, value: typing.Any, allowed: str, *,
                 file: str | Path | None = None):
        self.field, self.value, self.allowed = field, value, allowed
        self.file = None if file is None else str(file)
        super().__init__(self._line())

    def _line(self) -> str:
        where = "" if self.file is None else f"{self.file}: "
        text = f"{where}{self.field}: got {shorten(self.value)}; allowed: {self.allowed}"
        return " ".join(text.splitlines())

    def in_file(self, file: str | Path) -> "InputError":
        """This error, naming ``file`` unless it already names one."""
        if self.file is None:
            self.file = str(file)
            self.args = (self._line(),)
        return self

    def __str__(self) -> str:
        return self._line()


_SHORT = reprlib.Repr()
_SHORT.maxstring, _SHORT.maxother, _SHORT.maxlist, _SHORT.maxdict = 120, 60, 6, 4
_SHORT.maxlevel = 3


def shorten(value: typing.Any, most: int = 160) -> str:
    """A one-line repr of ``value`` of at most ``most`` characters."""
    text = " ".join(_SHORT.repr(value).split())
    return text if len(text) <= most else text[:most - 3] + "..."
