/* placeholder */
typedef int hv_placeholder_image;
