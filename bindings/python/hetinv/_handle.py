"""Ownership of C handles: deterministic close(), context managers, a
destruction order the garbage collector cannot break, and handle type checks.

Each wrapper object (Medium, Emitter, ...) holds an _Owner, a small object
that owns the C handle. An owner references only the owners of its parents:
the objects the C object needs to outlive it (its context, and whatever the
C object borrows: a measurement set its emitters, sensors and pathlengths,
an optimizer its set and maps). It never references a wrapper, so owners
form a graph without cycles, and every parent also counts its live
children.

Why both: the cycle collector calls the finalizers of everything a dead
cycle holds in an arbitrary order, owners included, and clears weak
references before it does. So an owner's finalizer never destroys a C
object that still has live children: it marks it pending, and the last
child destroyed destroys its parent. Outside the collector, refcounting
frees children first anyway (a child's owner holds its parents' owners).

close() destroys the object now, and first everything that depends on it
(found through weak references): closing a context closes everything made
from it, closing an emitter the sets that use it. While a long C call runs
(an optimizer run, whose progress callback may call back into Python, or a
render, while another thread may call close()), its objects are pinned and
closing any of them, or anything they depend on, is refused.

An estimator and an optimizer belong to one thread at a time (their C
headers): methods marked @one_thread claim the object for the calling
thread, and a call from another thread while it is claimed raises instead
of racing in C (two threads' passes on one estimator crashed the
interpreter). The owning thread may call in again (an optimizer's progress
callback rendering with the run's estimator).
"""
import contextlib
import ctypes
import functools
import itertools
import threading
import weakref

from ._lib import lib

# Finalizers may run on any thread, in the middle of another close().
_lock = threading.RLock()
_keys = itertools.count()


class _Owner:
    """Owns one C handle; see the module's docstring."""

    __slots__ = ("h", "destroy", "parents", "children", "live", "pending", "busy", "key",
                 "user", "uses", "__weakref__")

    def __init__(self, handle, destroy, parents):
        self.h = handle            # ctypes.c_void_p; NULL once destroyed
        self.destroy = destroy     # the C destroy function (kept: no global lookup at exit)
        self.parents = []          # owners this one keeps alive
        self.children = weakref.WeakValueDictionary()  # for close(): key -> child owner
        self.live = 0              # children whose C object is not destroyed yet
        self.pending = False       # closed or finalized while children were alive
        self.busy = 0              # > 0 while a long C call uses it (see pinned())
        self.key = next(_keys)
        self.user = None           # the thread that has claimed it (see exclusive())
        self.uses = 0              # its nested claims
        for p in parents:
            self.add_parent(p)

    def add_parent(self, parent):
        with _lock:
            if any(parent is p for p in self.parents):
                return
            self.parents.append(parent)
            parent.children[self.key] = self
            parent.live += 1

    def check_closable(self, what):
        if self.busy:
            raise RuntimeError("cannot close %s: a running call (an optimizer run or a render) "
                               "uses it" % what)
        for child in list(self.children.values()):
            child.check_closable(what)

    def close(self):
        """Destroy the C object after every child (closing them first)."""
        with _lock:
            for child in sorted(self.children.values(), key=lambda c: -c.key):
                child.close()
            self.pending = True
            self._destroy_if_free()

    def _destroy_if_free(self):
        if not self.h or self.live > 0:
            return
        self.destroy(ctypes.byref(self.h))  # sets the C handle to NULL
        self.h = ctypes.c_void_p()
        parents, self.parents = self.parents, []
        for p in parents:
            p.children.pop(self.key, None)
            p.live -= 1
            if p.pending:
                p._destroy_if_free()

    def __del__(self):
        try:
            with _lock:
                self.pending = True
                self._destroy_if_free()
        except Exception:  # interpreter shutdown: nothing sensible to do
            pass


@contextlib.contextmanager
def pinned(*objects):
    """Refuse close() of `objects` (and of what they depend on) during the
    block: the C call in it uses their handles."""
    owners = [o._owner for o in objects]
    with _lock:
        for o in objects:
            o._ptr  # closed: ValueError
        for o in owners:
            o.busy += 1
    try:
        yield
    finally:
        with _lock:
            for o in owners:
                o.busy -= 1


@contextlib.contextmanager
def exclusive(*objects):
    """Claim `objects` for the calling thread during the block; a
    RuntimeError if another thread has claimed one of them."""
    me = threading.get_ident()
    owners = [o._owner for o in objects]
    with _lock:
        for o, owner in zip(objects, owners):
            if owner.user is not None and owner.user != me:
                name = type(o).__name__
                raise RuntimeError("this hetinv.%s is in use by another thread: a hetinv.%s belongs to one "
                                   "thread at a time (make one per thread)" % (name, name))
        for owner in owners:
            owner.user = me
            owner.uses += 1
    try:
        yield
    finally:
        with _lock:
            for owner in owners:
                owner.uses -= 1
                if owner.uses == 0:
                    owner.user = None


def one_thread(method):
    """A method of an object that belongs to one thread at a time: it
    claims the object for its call (exclusive())."""
    @functools.wraps(method)
    def claimed(self, *args, **kwargs):
        with exclusive(self):
            return method(self, *args, **kwargs)
    return claimed


def handle_arg(obj, cls, name):
    """The C handle of `obj` after checking that it is an open `cls`; a
    TypeError naming the parameter otherwise (a C call given a handle of
    another type would read it as the wrong struct)."""
    if not isinstance(obj, cls):
        raise TypeError("%s: expected hetinv.%s, got %s"
                        % (name, cls.__name__, _type_name(obj)))
    return obj._ptr


def _type_name(obj):
    t = type(obj)
    return "hetinv." + t.__name__ if isinstance(obj, Handle) else t.__name__


class Handle:
    """Base of every wrapper of a C handle."""

    _destroy_name = None  # e.g. "medium_destroy"
    _owner = None

    def __init__(self, handle, parents=()):
        self._owner = _Owner(handle, getattr(lib, self._destroy_name),
                             [p._owner for p in parents])

    @classmethod
    def _wrap(cls, handle, parents):
        obj = cls.__new__(cls)
        Handle.__init__(obj, handle, parents)
        return obj

    def _borrow(self, *objects):
        """Keep `objects` alive as long as this one, and close this one first
        if any of them is closed."""
        for o in objects:
            if o is not None:
                self._owner.add_parent(o._owner)

    @property
    def _deps(self):
        """The owners of the objects that depend on this one (live ones)."""
        return self._owner.children if self._owner is not None else {}

    @property
    def _ptr(self):
        if self.closed:
            raise ValueError("operation on a closed %s" % type(self).__name__)
        return self._owner.h

    @property
    def closed(self):
        """True once close() has run (or the object it depends on was closed)."""
        o = self._owner
        return o is None or o.pending or not o.h

    def close(self):
        """Destroy the C object now (and first every object that depends on
        it). Calling it again does nothing."""
        o = self._owner
        if o is None or o.pending or not o.h:
            return
        with _lock:  # no pinned() in between
            o.check_closable("this %s" % type(self).__name__)
            o.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def __reduce_ex__(self, protocol):
        # pickle and deepcopy would fail inside ctypes ("objects containing
        # pointers cannot be pickled"); say what the object is instead.
        raise TypeError("hetinv.%s holds a C object and cannot be pickled or deep-copied%s"
                        % (type(self).__name__, "; use clone()" if hasattr(self, "clone") else ""))

    def __copy__(self):
        return self  # one C object: a shallow copy is the object itself

    def __repr__(self):
        state = "closed" if self.closed else "0x%x" % self._owner.h.value
        return "<hetinv.%s %s>" % (type(self).__name__, state)
