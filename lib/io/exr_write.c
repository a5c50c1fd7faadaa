/* placeholder */
typedef int hv_placeholder_exr_write;
