"""Images through Python: an OpenEXR file written by the library reads back
with the same pixels, channel names and attributes; PNG previews are
written; bad channels, names and files raise with the library's words."""
import os
import struct
import tempfile
import unittest

import hetinv


def bits(values):
    v = [float(x) for x in hetinv.flat(values)]
    return struct.pack("%df" % len(v), *v)


class Images(unittest.TestCase):
    def setUp(self):
        self.ctx = hetinv.Context(seed=1, threads=1)
        self.dir = tempfile.TemporaryDirectory()

    def tearDown(self):
        self.ctx.close()
        self.dir.cleanup()

    def path(self, name):
        return os.path.join(self.dir.name, name)

    def test_exr_round_trip_keeps_pixels_names_order_and_attributes(self):
        img = hetinv.Image(self.ctx, 3, 2, channels=2)
        self.assertEqual(img.size, (3, 2, 2))
        self.assertEqual(img.channel_names, ["c0", "c1"])
        # "zeta" before "alpha": OpenEXR sorts channels by name, the library
        # restores the order it wrote.
        img.rename_channel(0, "zeta").rename_channel("c1", "alpha")
        zeta = [0.5, -1.25, 3.0e-7, 1.0e30, 0.0, 7.0]
        img.set_channel("zeta", zeta)
        img.set_channel(1, [float(i) for i in range(6)])
        img.set_attribute("hetinv:key", "config=4 volume=3")
        img.set_attribute("photons", 8000)
        img.set_attribute("scale", 0.1)
        img.write_exr(self.path("a.exr"))

        back = hetinv.read_exr(self.ctx, self.path("a.exr"))
        self.assertEqual(back.size, (3, 2, 2))
        self.assertEqual(back.channel_names, ["zeta", "alpha"])
        self.assertEqual(bits(back["zeta"]), bits(zeta))
        self.assertEqual(bits(back.channel(1)), bits(range(6)))
        attrs = back.attributes
        self.assertEqual(attrs["hetinv:key"], "config=4 volume=3")
        self.assertEqual(attrs["photons"], 8000)
        self.assertIsInstance(attrs["photons"], int)
        self.assertEqual(attrs["scale"], 0.1)
        if hetinv.numpy_enabled():
            self.assertEqual(back["alpha"].shape, (2, 3))
            self.assertEqual(back["alpha"][1, 0], 3.0)  # pixel (x 0, y 1)

    def test_channels_are_copies(self):
        img = hetinv.Image(self.ctx, 2, 1)
        a = img[0]
        hetinv.flat(a)[0] = 5.0
        self.assertEqual(list(hetinv.flat(img[0])), [0.0, 0.0])

    def test_without_numpy_channels_are_flat_float_arrays(self):
        previous = hetinv.use_numpy(False)
        try:
            img = hetinv.Image(self.ctx, 3, 2)
            img.set_channel(0, [0.5] * 6)
            img.write_exr(self.path("f.exr"))
            c = hetinv.read_exr(self.ctx, self.path("f.exr"))[0]
            self.assertEqual((c.typecode, list(c)), ("f", [0.5] * 6))
        finally:
            hetinv.use_numpy(previous)

    def test_png_preview_is_written(self):
        img = hetinv.Image(self.ctx, 4, 4)
        img.set_channel(0, [float(i) for i in range(16)])
        img.write_png(0, self.path("v.png"))
        img.write_png("c0", self.path("g.png"), lo=0.0, hi=15.0, colormap="gray")
        for name in ("v.png", "g.png"):
            with open(self.path(name), "rb") as f:
                self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")

    def test_bad_input_raises_with_the_library_message(self):
        img = hetinv.Image(self.ctx, 2, 2)
        with self.assertRaisesRegex(KeyError, "no channel 'sigma'; the image has c0"):
            img["sigma"]
        with self.assertRaisesRegex(IndexError, "channel 1 is out of range"):
            img.channel(1)
        with self.assertRaisesRegex(ValueError, "expected 4 values, got 3"):
            img.set_channel(0, [1.0, 2.0, 3.0])
        with self.assertRaises(hetinv.InvalidArgumentError):
            img.set_attribute("channels", "x")  # reserved by OpenEXR
        # A NUL would end the C string early: another name than the one given.
        with self.assertRaisesRegex(ValueError, "embedded null"):
            img.set_attribute("a\0b", 1)
        with self.assertRaisesRegex(ValueError, "embedded null"):
            img.set_attribute("note", "x\0y")
        with self.assertRaisesRegex(ValueError, "embedded null"):
            img.rename_channel(0, "c\0")
        with self.assertRaisesRegex(TypeError, "name: expected a str"):
            img.set_attribute(b"key", 1)
        self.assertEqual(img.attributes, {})
        with self.assertRaises(hetinv.InvalidArgumentError):
            img.set_attribute("x", float("nan"))
        with self.assertRaises(hetinv.InvalidArgumentError):
            hetinv.Image(self.ctx, 0, 2)
        with self.assertRaisesRegex(ValueError, "unknown colormap 'jet'"):
            img.write_png(0, self.path("x.png"), colormap="jet")
        with self.assertRaises(hetinv.FileIOError):
            hetinv.read_exr(self.ctx, self.path("missing.exr"))
        with open(self.path("bad.exr"), "wb") as f:
            f.write(b"\x76\x2f\x31\x01" + b"\0" * 40)
        with self.assertRaises(hetinv.HetinvError) as e:
            hetinv.read_exr(self.ctx, self.path("bad.exr"))
        self.assertIn("bad.exr", str(e.exception))
        self.assertFalse(os.path.exists(self.path("x.png")))

    def test_closing_the_context_closes_its_images(self):
        img = hetinv.Image(self.ctx, 1, 1)
        self.ctx.close()
        self.assertTrue(img.closed)
        with self.assertRaisesRegex(ValueError, "closed Image"):
            img.size


if __name__ == "__main__":
    unittest.main()
