/* placeholder */
typedef int hv_placeholder_png_write;
