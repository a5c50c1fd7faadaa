"""Every C function the binding declares exists in the public headers with
the same number of parameters, so a changed signature is caught here rather
than by a crash; lists what the binding leaves out."""
import os
import re
import unittest

from hetinv import _lib

DECL = re.compile(r"HETINV_API\s+([^;{]*?)\b(hetinv_\w+)\s*\(([^;]*?)\)\s*;", re.S)


def declarations():
    include = os.path.join(os.environ["HETINV_INCLUDE_DIR"], "hetinv")
    found = {}
    for name in sorted(os.listdir(include)):
        if name.endswith((".h", ".h.in")):  # version.h is generated from version.h.in
            with open(os.path.join(include, name), encoding="utf-8") as f:
                text = re.sub(r"/\*.*?\*/", "", f.read(), flags=re.S)
            for m in DECL.finditer(text):
                params = m.group(3).strip()
                n = 0 if params in ("", "void") else params.count(",") + 1
                found[m.group(2)] = (m.group(1).strip(), n)
    return found


class Prototypes(unittest.TestCase):
    @unittest.skipUnless(os.environ.get("HETINV_INCLUDE_DIR"), "HETINV_INCLUDE_DIR not set")
    def test_declared_functions_match_the_headers(self):
        decls = declarations()
        self.assertGreater(len(decls), 90)
        for name, (restype, argtypes) in _lib.PROTOTYPES.items():
            self.assertTrue(name in decls, "%s is not in the public headers" % name)
            c_ret, c_n = decls[name]
            self.assertEqual(len(argtypes), c_n, "%s: %d parameters in C" % (name, c_n))
            self.assertEqual(restype is None, c_ret == "void", "%s returns %s" % (name, c_ret))
        left_out = sorted(set(decls) - set(_lib.PROTOTYPES))
        # An MPI communicator cannot cross ctypes portably (mpi4py users call
        # the C function directly).
        self.assertEqual([n for n in left_out if n != "hetinv_context_set_mpi_comm"], [])

    def test_every_declared_function_is_in_the_library(self):
        for name in _lib.PROTOTYPES:
            self.assertTrue(hasattr(_lib.lib, name[len("hetinv_"):]), name)


if __name__ == "__main__":
    unittest.main()
