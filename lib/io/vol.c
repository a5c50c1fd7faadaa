/* placeholder */
typedef int hv_placeholder_vol;
