/* placeholder */
typedef int hv_placeholder_medium_vol;
