"""Loading libhetinv and declaring the C functions the binding calls.

Every C function the package uses is declared in PROTOTYPES below, with its
argument and result types; `lib` exposes only those, so calling a function
without a declaration is an AttributeError rather than a silent int-typed
call. tests/python/test_prototypes.py checks the table against the headers.
"""
import ctypes
import ctypes.util
import os

from ._structs import (
    ContextInit,
    MixtureSpec,
    NoiseModel,
    Progress,
    RenderStats,
    SmokeSpec,
    Stage,
    VolHeader,
)

c_double_p = ctypes.POINTER(ctypes.c_double)
c_float_p = ctypes.POINTER(ctypes.c_float)
c_int32_p = ctypes.POINTER(ctypes.c_int32)
c_uint8_p = ctypes.POINTER(ctypes.c_uint8)
c_size_t_p = ctypes.POINTER(ctypes.c_size_t)
c_void_pp = ctypes.POINTER(ctypes.c_void_p)
c_char_pp = ctypes.POINTER(ctypes.c_char_p)

#: int (*)(const hetinv_progress_t *, void *)
PROGRESS_FN = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.POINTER(Progress), ctypes.c_void_p)

_i32, _u32, _u64, _sz, _d, _vp, _cp = (ctypes.c_int32, ctypes.c_uint32, ctypes.c_uint64,
                                       ctypes.c_size_t, ctypes.c_double, ctypes.c_void_p,
                                       ctypes.c_char_p)
_R = ctypes.c_int32  # hetinv_result_t

# name: (restype, [argtypes]); None restype = void. Handles are void pointers.
PROTOTYPES = {
    # version.h, result.h, context.h
    "hetinv_version_number": (ctypes.c_uint, []),
    "hetinv_version_string": (_cp, []),
    "hetinv_result_name": (_cp, [_R]),
    "hetinv_context_create": (_R, [ctypes.POINTER(ContextInit), c_void_pp]),
    "hetinv_context_destroy": (None, [c_void_pp]),
    "hetinv_context_thread_count": (_i32, [_vp]),
    "hetinv_context_seed": (_u64, [_vp]),
    "hetinv_context_rank": (_i32, [_vp]),
    "hetinv_context_rank_count": (_i32, [_vp]),
    "hetinv_context_agree": (_R, [_vp, _R]),
    "hetinv_build_has_mpi": (ctypes.c_int, []),
    "hetinv_context_last_error_message": (_cp, [_vp]),
    "hetinv_context_last_error_code": (_R, [_vp]),
    "hetinv_context_last_error_rank": (_i32, [_vp]),
    # medium.h
    "hetinv_param_name": (_cp, [_i32]),
    "hetinv_medium_create": (_R, [_vp, c_double_p, c_double_p, c_int32_p, c_void_pp]),
    "hetinv_medium_clone": (_R, [_vp, c_void_pp]),
    "hetinv_medium_destroy": (None, [c_void_pp]),
    "hetinv_medium_set_ior": (_R, [_vp, _d, _d]),
    "hetinv_medium_fill": (_R, [_vp, _d, _d, _d]),
    "hetinv_medium_set_voxel": (_R, [_vp, _i32, _i32, _i32, _d, _d, _d]),
    "hetinv_medium_set_grid": (_R, [_vp, _i32, c_double_p, _sz]),
    "hetinv_medium_commit": (_R, [_vp]),
    "hetinv_medium_is_committed": (ctypes.c_int, [_vp]),
    "hetinv_medium_context": (_vp, [_vp]),
    "hetinv_medium_get_dims": (_R, [_vp, c_int32_p]),
    "hetinv_medium_voxel_count": (_sz, [_vp]),
    "hetinv_medium_get_box": (_R, [_vp, c_double_p, c_double_p]),
    "hetinv_medium_get_ior": (_R, [_vp, c_double_p, c_double_p]),
    "hetinv_medium_get_voxel": (_R, [_vp, _i32, _i32, _i32, c_double_p, c_double_p, c_double_p]),
    "hetinv_medium_grid": (c_double_p, [_vp, _i32]),
    # io.h (.vol)
    "hetinv_vol_read_header": (_R, [_vp, _cp, ctypes.POINTER(VolHeader)]),
    "hetinv_vol_read": (_R, [_vp, _cp, ctypes.POINTER(VolHeader), c_float_p, _sz]),
    "hetinv_vol_write": (_R, [_vp, _cp, ctypes.POINTER(VolHeader), c_float_p, _sz]),
    "hetinv_medium_read_vol": (_R, [_vp, _i32, _cp]),
    "hetinv_medium_write_vol": (_R, [_vp, _i32, _cp]),
    # io.h (images: OpenEXR, PNG)
    "hetinv_image_create": (_R, [_vp, _i32, _i32, _i32, c_void_pp]),
    "hetinv_image_destroy": (None, [c_void_pp]),
    "hetinv_image_get_size": (_R, [_vp, c_int32_p, c_int32_p, c_int32_p]),
    "hetinv_image_channel_data": (c_float_p, [_vp, _i32]),
    "hetinv_image_set_channel_name": (_R, [_vp, _i32, _cp]),
    "hetinv_image_channel_name": (_cp, [_vp, _i32]),
    "hetinv_image_find_channel": (_R, [_vp, _cp, c_int32_p]),
    "hetinv_image_set_attribute_string": (_R, [_vp, _cp, _cp]),
    "hetinv_image_set_attribute_double": (_R, [_vp, _cp, _d]),
    "hetinv_image_set_attribute_int": (_R, [_vp, _cp, _i32]),
    "hetinv_image_attribute_count": (_i32, [_vp]),
    "hetinv_image_attribute_at": (_R, [_vp, _i32, c_char_pp, c_int32_p]),
    "hetinv_image_get_attribute_string": (_R, [_vp, _cp, c_char_pp]),
    "hetinv_image_get_attribute_double": (_R, [_vp, _cp, c_double_p]),
    "hetinv_image_get_attribute_int": (_R, [_vp, _cp, c_int32_p]),
    "hetinv_image_write_exr": (_R, [_vp, _cp]),
    "hetinv_image_read_exr": (_R, [_vp, _cp, c_void_pp]),
    "hetinv_image_write_png": (_R, [_vp, _i32, _cp, _d, _d, _i32]),
    # sampling.h
    "hetinv_emitter_create_ideal": (_R, [_vp, c_double_p, c_double_p, c_void_pp]),
    "hetinv_emitter_create_area": (_R, [_vp, _i32, c_double_p, c_double_p, c_double_p, _i32,
                                        _i32, c_double_p, c_void_pp]),
    "hetinv_emitter_create_diffuse": (_R, [_vp, _i32, c_double_p, c_void_pp]),
    "hetinv_emitter_create_combination": (_R, [_vp, _i32, c_double_p, c_double_p, c_double_p,
                                               c_void_pp]),
    "hetinv_emitter_destroy": (None, [c_void_pp]),
    "hetinv_sensor_create_orthographic": (_R, [_vp, _i32, c_double_p, c_double_p, c_double_p,
                                               _i32, _i32, c_void_pp]),
    "hetinv_sensor_create_hemispherical": (_R, [_vp, _i32, c_double_p, c_double_p, c_void_pp]),
    "hetinv_sensor_create_fiber": (_R, [_vp, _i32, c_double_p, _d, _d, c_void_pp]),
    "hetinv_sensor_pixel_count": (_i32, [_vp]),
    "hetinv_sensor_get_size": (_R, [_vp, c_int32_p, c_int32_p]),
    "hetinv_sensor_destroy": (None, [c_void_pp]),
    "hetinv_pathlength_create_steady": (_R, [_vp, c_void_pp]),
    "hetinv_pathlength_create_bins": (_R, [_vp, _i32, _i32, c_double_p, _d, c_void_pp]),
    "hetinv_pathlength_create_bins_irf": (_R, [_vp, _i32, _i32, c_double_p, _d, _i32, c_double_p,
                                              c_double_p, c_void_pp]),
    "hetinv_irf_offsets_from_times": (_R, [c_double_p, _sz, _d, _d, c_double_p]),
    "hetinv_pathlength_bin_count": (_i32, [_vp]),
    "hetinv_pathlength_destroy": (None, [c_void_pp]),
    # measurement.h
    "hetinv_measurements_create": (_R, [_vp, c_void_pp]),
    "hetinv_measurements_destroy": (None, [c_void_pp]),
    "hetinv_measurements_add": (_R, [_vp, _vp, _vp, _vp, c_int32_p]),
    "hetinv_measurements_row_count": (_i32, [_vp]),
    "hetinv_measurements_value_count": (_sz, [_vp]),
    "hetinv_measurements_row_layout": (_R, [_vp, _i32, c_size_t_p, c_int32_p, c_int32_p]),
    "hetinv_measurements_set_values": (_R, [_vp, c_double_p, c_double_p, _sz]),
    "hetinv_measurements_set_weights": (_R, [_vp, c_double_p, _sz]),
    "hetinv_measurements_set_clip_scales": (_R, [_vp, c_double_p, c_double_p, _sz]),
    "hetinv_measurements_set_mask": (_R, [_vp, c_uint8_p, _sz]),
    "hetinv_measurements_mask_saturated": (_R, [_vp, _d, c_size_t_p]),
    "hetinv_measurements_values": (c_double_p, [_vp]),
    "hetinv_measurements_std_errors": (c_double_p, [_vp]),
    "hetinv_measurements_weights": (c_double_p, [_vp]),
    "hetinv_measurements_clip_scales_below": (c_double_p, [_vp]),
    "hetinv_measurements_clip_scales_above": (c_double_p, [_vp]),
    "hetinv_measurements_mask": (c_uint8_p, [_vp]),
    # estimator.h
    "hetinv_estimator_create": (_R, [_vp, c_void_pp]),
    "hetinv_estimator_destroy": (None, [c_void_pp]),
    "hetinv_estimator_param_bounds": (_R, [_i32, c_double_p, c_double_p]),
    "hetinv_estimator_set_param": (_R, [_vp, _i32, _d]),
    "hetinv_estimator_get_param": (_R, [_vp, _i32, c_double_p]),
    "hetinv_estimator_render": (_R, [_vp, _vp, _vp, c_double_p, c_double_p, c_double_p, _sz]),
    "hetinv_estimator_gradient": (_R, [_vp, _vp, _vp, c_double_p, _sz, _vp, c_double_p,
                                       c_double_p, _sz]),
    "hetinv_estimator_loss_gradient": (_R, [_vp, _vp, _vp, _vp, c_double_p, c_double_p,
                                            c_double_p, _sz]),
    "hetinv_estimator_get_stats": (_R, [_vp, ctypes.POINTER(RenderStats)]),
    "hetinv_estimator_set_gain_mode": (_R, [_vp, _i32]),
    "hetinv_estimator_get_gain_mode": (_R, [_vp, c_int32_p]),
    "hetinv_estimator_get_gains": (_R, [_vp, c_double_p, _sz, c_size_t_p]),
    "hetinv_estimator_jvp": (_R, [_vp, _vp, _vp, _vp, c_double_p, _sz, c_double_p, c_double_p, _sz]),
    # bound.h
    "hetinv_estimator_fisher": (_R, [_vp, _vp, _vp, c_double_p, _sz, _vp, _i32, c_double_p,
                                     c_double_p, _sz]),
    "hetinv_estimator_crb": (_R, [_vp, _vp, _vp, c_double_p, _sz, _vp, _i32, c_double_p, c_double_p,
                                  c_double_p, _sz, c_int32_p]),
    "hetinv_estimator_fisher_diagonal": (_R, [_vp, _vp, _vp, c_double_p, _sz, _vp, _i32, c_double_p,
                                              c_double_p, _sz]),
    "hetinv_fisher_local_crb": (_R, [_vp, c_double_p, _sz, _i32, c_double_p]),
    "hetinv_estimator_fisher_blocks": (_R, [_vp, _vp, _vp, c_double_p, _sz, _vp, _i32, _i32, c_double_p,
                                            c_double_p, _sz]),
    "hetinv_fisher_blocks_crb": (_R, [_vp, c_double_p, _sz, c_double_p]),
    # param.h
    "hetinv_param_map_create_identity": (_R, [_vp, _u32, c_void_pp]),
    "hetinv_param_map_create_coarse": (_R, [_vp, c_int32_p, _u32, c_void_pp]),
    "hetinv_param_map_create_broadcast": (_R, [_vp, _i32, _u32, c_void_pp]),
    "hetinv_param_map_destroy": (None, [c_void_pp]),
    "hetinv_param_map_size": (_sz, [_vp]),
    "hetinv_param_map_free_mask": (_u32, [_vp]),
    "hetinv_param_map_get_dims": (_R, [_vp, c_int32_p]),
    "hetinv_param_map_entry": (_R, [_vp, _sz, c_int32_p, c_size_t_p]),
    "hetinv_param_map_apply": (_R, [_vp, c_double_p, _sz, _vp]),
    "hetinv_param_map_extract": (_R, [_vp, _vp, c_double_p, _sz]),
    "hetinv_param_map_pullback": (_R, [_vp, c_double_p, c_double_p, _sz]),
    # optimizer.h
    "hetinv_optimizer_create": (_R, [_vp, _vp, _vp, c_void_pp]),
    "hetinv_optimizer_destroy": (None, [c_void_pp]),
    "hetinv_optimizer_param_bounds": (_R, [_i32, c_double_p, c_double_p]),
    "hetinv_optimizer_set_param": (_R, [_vp, _i32, _d]),
    "hetinv_optimizer_get_param": (_R, [_vp, _i32, c_double_p]),
    "hetinv_optimizer_set_bounds": (_R, [_vp, _i32, _d, _d]),
    "hetinv_optimizer_add_stage": (_R, [_vp, ctypes.POINTER(Stage)]),
    "hetinv_optimizer_add_layerwise_stages": (_R, [_vp, _vp, _d, _i32, _i32]),
    "hetinv_optimizer_set_progress": (_R, [_vp, PROGRESS_FN, _vp]),
    "hetinv_optimizer_set_checkpoint": (_R, [_vp, _cp]),
    "hetinv_optimizer_save": (_R, [_vp, _cp]),
    "hetinv_optimizer_resume": (_R, [_vp, _cp]),
    "hetinv_optimizer_run": (_R, [_vp, _vp, c_int32_p]),
    "hetinv_optimizer_result": (_R, [_vp, c_void_pp]),
    "hetinv_optimizer_get_pi": (_R, [_vp, ctypes.c_int, c_double_p, _sz]),
    "hetinv_optimizer_losses": (c_double_p, [_vp, c_size_t_p]),
    # acquire.h
    "hetinv_noise_model_default": (None, [ctypes.POINTER(NoiseModel)]),
    "hetinv_noise_apply": (_R, [_vp, ctypes.POINTER(NoiseModel), c_double_p, c_double_p,
                                c_double_p, _sz, c_double_p]),
    "hetinv_mixture_spec_default": (None, [ctypes.POINTER(MixtureSpec)]),
    "hetinv_volume_gaussian_mixture": (_R, [_vp, ctypes.POINTER(MixtureSpec)]),
    "hetinv_smoke_spec_default": (None, [ctypes.POINTER(SmokeSpec)]),
    "hetinv_volume_smoke": (_R, [_vp, ctypes.POINTER(SmokeSpec)]),
}


#: Where an installed libhetinv usually is, tried after pkg-config.
COMMON_LIBDIRS = ("/usr/local/lib", "/usr/local/lib64", "/usr/local/lib/x86_64-linux-gnu",
                  "/usr/lib/x86_64-linux-gnu", "/usr/lib64", "/usr/lib")
SONAME = "libhetinv.so.0"  # SOVERSION 0 (CMakeLists.txt)


def _pkg_config_libdir():
    """`pkg-config --variable=libdir hetinv` (honours PKG_CONFIG_PATH), or
    None if pkg-config or hetinv.pc is not there."""
    import subprocess

    try:
        out = subprocess.run(["pkg-config", "--variable=libdir", "hetinv"], stdout=subprocess.PIPE,
                             stderr=subprocess.DEVNULL, timeout=10, check=True)
    except (OSError, subprocess.SubprocessError):
        return None
    libdir = out.stdout.decode(errors="replace").strip()
    return os.path.normpath(libdir) if libdir else None  # hetinv.pc says ${pcfiledir}/../..


def _candidates():
    """(what, name or path) to try, in order; each is loaded lazily, so
    pkg-config only runs when the earlier ones failed."""
    env = os.environ.get("HETINV_LIBRARY")
    if env:
        yield "HETINV_LIBRARY", env  # an explicit choice is never second-guessed
        return
    yield "ctypes.util.find_library", ctypes.util.find_library("hetinv")
    libdir = _pkg_config_libdir()
    yield "pkg-config libdir", os.path.join(libdir, SONAME) if libdir else None
    for d in COMMON_LIBDIRS:
        yield d, os.path.join(d, SONAME)
    yield "the dynamic loader (LD_LIBRARY_PATH)", SONAME


def _load():
    tried = []
    for what, name in _candidates():
        if name is None:
            tried.append("%s: nothing found" % what)
            continue
        if os.path.isabs(name) and not os.path.exists(name) and what != "HETINV_LIBRARY":
            tried.append("%s: no %s" % (what, name))
            continue
        try:
            return ctypes.CDLL(name), name
        except OSError as e:
            tried.append("%s: %s" % (what, e))
    raise ImportError("hetinv: cannot load libhetinv (set HETINV_LIBRARY to the path of "
                      "libhetinv.so, or install libhetinv where ctypes.util.find_library, "
                      "pkg-config (PKG_CONFIG_PATH) or the dynamic loader finds it). Looked at:\n  "
                      + "\n  ".join(tried))


class _Declared:
    """The library's functions, each with its declared prototype; nothing else."""

    def __init__(self, cdll):
        for name, (restype, argtypes) in PROTOTYPES.items():
            f = getattr(cdll, name)  # AttributeError: the library lacks a function we bind
            f.restype = restype
            f.argtypes = argtypes
            setattr(self, name[len("hetinv_"):], f)


_cdll, path = _load()
lib = _Declared(_cdll)
