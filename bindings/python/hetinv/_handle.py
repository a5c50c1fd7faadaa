"""Ownership of C handles: deterministic close(), context managers, and
keeping what the C side borrows alive.

Each wrapper object owns one C handle. It holds strong references to the
objects it needs (its context, and whatever the C object borrows: a
measurement set its emitters, sensors and pathlengths; an optimizer its set,
maps and medium), so Python never frees those first. In the other direction
each object keeps weak references to the objects that depend on it, and
close() closes those first: closing a context closes everything made from
it, closing an emitter closes the sets that use it. No C object is ever
destroyed while another still points to it.
"""
import ctypes
import weakref

from ._lib import lib


class Handle:
    """Base of every wrapper of a C handle."""

    _destroy_name = None  # e.g. "medium_destroy"

    def __init__(self, handle, parents=()):
        self._h = handle  # ctypes.c_void_p
        self._destroy = getattr(lib, self._destroy_name)
        self._parents = list(parents)
        self._deps = {}
        for p in self._parents:
            p._adopt(self)

    @classmethod
    def _wrap(cls, handle, parents):
        obj = cls.__new__(cls)
        Handle.__init__(obj, handle, parents)
        return obj

    def _adopt(self, child):
        key = id(child)
        deps = self._deps
        deps[key] = weakref.ref(child, lambda _r, key=key, deps=deps: deps.pop(key, None))

    def _borrow(self, *objects):
        """Keep `objects` alive as long as this one, and close this one first
        if any of them is closed."""
        for o in objects:
            if o is not None and all(o is not p for p in self._parents):
                self._parents.append(o)
                o._adopt(self)

    @property
    def _ptr(self):
        if not self._h:
            raise ValueError("operation on a closed %s" % type(self).__name__)
        return self._h

    @property
    def closed(self):
        """True once close() has run."""
        return not self._h

    def close(self):
        """Destroy the C object now (and first every object that depends on
        it). Calling it again does nothing."""
        h = getattr(self, "_h", None)
        if not h:
            return
        for ref in reversed(list(self._deps.values())):
            dep = ref()
            if dep is not None:
                dep.close()
        self._deps.clear()
        self._destroy(ctypes.byref(h))  # sets the C handle to NULL
        self._h = ctypes.c_void_p()
        for p in self._parents:
            p._deps.pop(id(self), None)
        self._parents = []

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def __del__(self):
        try:
            self.close()
        except Exception:  # interpreter shutdown: nothing sensible to do
            pass

    def __repr__(self):
        state = "closed" if self.closed else "0x%x" % self._h.value
        return "<hetinv.%s %s>" % (type(self).__name__, state)
