"""The context: base seed, thread count, error messages."""
import ctypes

from ._args import integer
from ._errors import FileIOError, check
from ._handle import Handle
from ._lib import lib
from ._structs import ContextInit


class Context(Handle):
    """hetinv_context_t. Every other object is made from a context, which
    keeps them in order: close() first closes everything made from it.

        with hetinv.Context(seed=7, threads=2) as ctx:
            ...
    """

    _destroy_name = "context_destroy"

    def __init__(self, seed=0, threads=0):
        init = ContextInit(seed=integer(seed, "seed", "uint64"),
                           thread_count=integer(threads, "threads"))
        h = ctypes.c_void_p()
        check(lib.context_create(ctypes.byref(init), ctypes.byref(h)))
        super().__init__(h)

    @property
    def seed(self):
        return lib.context_seed(self._ptr)

    @property
    def thread_count(self):
        return lib.context_thread_count(self._ptr)

    @property
    def rank(self):
        """This process's MPI rank in the context's communicator (0 without MPI)."""
        return lib.context_rank(self._ptr)

    @property
    def rank_count(self):
        """Ranks sharing the context's work (1 without MPI)."""
        return lib.context_rank_count(self._ptr)

    def last_error_message(self):
        """Message of this context's last failure on the calling thread ("" if none)."""
        return lib.context_last_error_message(self._ptr).decode("utf-8", "replace")

    def last_error_code(self):
        return lib.context_last_error_code(self._ptr)

    def last_error_rank(self):
        """MPI rank this context's last failure arose on (-1 if none): a
        collective call that failed on one rank raises on every rank, and
        the others' message is a copy of the failing rank's, so a program
        prints it where last_error_rank() == rank."""
        return lib.context_last_error_rank(self._ptr)

    def agree(self, failed=False):
        """Collective under MPI (hetinv_context_agree): after a step one
        rank takes alone (rank 0 writing a file), every rank passes whether
        its own step failed, and every rank raises FileIOError if any did,
        so that all stop before the next collective call. Without MPI it
        raises exactly when `failed`."""
        check(lib.context_agree(self._ptr, FileIOError.code if failed else 0))
