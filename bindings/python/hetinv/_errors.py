"""Exceptions: one class per pinned result code, all under HetinvError.

Every non-zero hetinv_result_t becomes an exception carrying the code, its
static name (hetinv_result_name) and the library's detailed message for the
failing call (hetinv_context_last_error_message), e.g.
InvalidArgumentError("hetinv_medium_fill: sigma_s is -1; it must be >= 0").
Where a built-in exception means the same thing the class derives from it
too, so `except ValueError` also catches an InvalidArgumentError.
"""
from ._lib import lib


class HetinvError(Exception):
    """A libhetinv call failed. .code is the result code, .name its name
    ("HETINV_ERROR_INVALID_ARGUMENT"), .message the library's message."""

    code = None

    def __init__(self, message, code=None):
        super().__init__(message)
        if code is not None:
            self.code = code
        self.message = message
        self.name = lib.result_name(self.code if self.code is not None else -1).decode()


class NullArgumentError(HetinvError, TypeError):
    code = 1


class InvalidArgumentError(HetinvError, ValueError):
    code = 2


class OutOfRangeError(HetinvError, IndexError):
    code = 3


class OutOfMemoryError(HetinvError, MemoryError):
    code = 4


class InvalidStateError(HetinvError, RuntimeError):
    code = 5


class FileIOError(HetinvError, OSError):
    """HETINV_ERROR_IO: the operating system refused a file operation."""

    code = 6


class CorruptFileError(HetinvError, ValueError):
    code = 7


class UnsupportedError(HetinvError, NotImplementedError):
    code = 8


class SizeOverflowError(HetinvError, OverflowError):
    code = 9


class InternalError(HetinvError, RuntimeError):
    code = 10


_BY_CODE = {c.code: c for c in (NullArgumentError, InvalidArgumentError, OutOfRangeError,
                                OutOfMemoryError, InvalidStateError, FileIOError,
                                CorruptFileError, UnsupportedError, SizeOverflowError,
                                InternalError)}


def error_for(code, message):
    """The exception for a result code (HetinvError itself for a code this
    binding does not know: newer libraries may append codes)."""
    cls = _BY_CODE.get(code)
    if cls is None:
        return HetinvError(message, code)
    return cls(message)


def check(code):
    """Raise the exception for a non-zero result code, with the calling
    thread's last message (the failing call just ran on this thread)."""
    if code != 0:
        raw = lib.context_last_error_message(None)
        message = raw.decode("utf-8", "replace") if raw else ""
        raise error_for(code, message or lib.result_name(code).decode())
