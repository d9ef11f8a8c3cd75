/* The DBE chain from C on a host: one frame of a TI DCA1000 capture in, points out.
 *
 *   cc -O2 -I ffi example.c ffi/target/release/libdbe_radar_ffi.a -o example
 *   ./example ../shared/fixtures/ti-iwr6843-corner-reflector/adc_data_Raw_0.bin
 *
 * Prints one line per point: range, azimuth, elevation and Doppler bins, x y z (m),
 * radial velocity (m/s), power and SNR (dB). Exit code 0 on success, 1 on any error. */
#include <stdio.h>
#include "dbe_radar.h"

#define PRESET DBE_PRESET_IWR6843 /* 256 samples, 64 loops, 3 TX x 4 RX */

/* All memory is the caller's: static here, as on a microcontroller. */
static _Alignas(DBE_STATE_ALIGN) unsigned char state[DBE_IWR6843_STATE_BYTES_MAX];
static _Alignas(DBE_CUBE_ALIGN) unsigned char cube[DBE_IWR6843_CUBE_BYTES];
static int16_t raw[4 * 256 * 2], chirp[4 * 256 * 2];
static dbe_point_t points[256];

static int fail(const char *what, dbe_status_t s, const char *detail) {
    fprintf(stderr, "%s: %s%s%s\n", what, dbe_status_name(s), detail ? " " : "", detail ? detail : "");
    return 1;
}

int main(int argc, char **argv) {
    dbe_sizes_t sz;
    dbe_t *radar;
    const char *detail;
    dbe_status_t s = dbe_sizes(PRESET, &sz);
    if (s != DBE_OK) return fail("dbe_sizes", s, NULL);
    /* NULL config: the preset's waveform, antenna layout and the chain's defaults. */
    s = dbe_init(PRESET, state, sizeof state, cube, sizeof cube, NULL, &radar, &detail);
    if (s != DBE_OK) return fail("dbe_init", s, detail);

    FILE *f = argc > 1 ? fopen(argv[1], "rb") : NULL;
    if (!f) { fprintf(stderr, "usage: example CAPTURE.bin (a DCA1000 capture, 256 x 64, 3 TX)\n"); return 1; }
    /* DCA1000 order: loop -> TX slot -> RX -> sample; per RX, every 4 int16 are
     * I(n) I(n+1) Q(n) Q(n+1). The chain wants [rx][sample][I, Q]. */
    for (uint32_t k = 0; k < sz.loops; k++) {
        for (uint32_t t = 0; t < sz.tx; t++) {
            if (fread(raw, sizeof(int16_t), sz.chirp_values, f) != sz.chirp_values) {
                fprintf(stderr, "%s: shorter than one frame\n", argv[1]);
                return 1;
            }
            for (uint32_t i = 0; i < sz.chirp_values / 4; i++) {
                const int16_t *q = &raw[4 * i];
                int16_t *c = &chirp[4 * i];
                c[0] = q[0]; c[1] = q[2]; c[2] = q[1]; c[3] = q[3];
            }
            s = dbe_push_chirp(radar, (uint16_t)k, (uint8_t)t, chirp, sz.chirp_values);
            if (s != DBE_OK) return fail("dbe_push_chirp", s, NULL);
        }
    }
    fclose(f);

    dbe_frame_stats_t stats;
    size_t n;
    s = dbe_process_frame(radar, &stats);
    if (s != DBE_OK) return fail("dbe_process_frame", s, NULL);
    s = dbe_points(radar, points, sizeof points / sizeof points[0], &n);
    if (s != DBE_OK) return fail("dbe_points", s, NULL);
    printf("%u detections, %zu points\n", stats.detections, n);
    for (size_t i = 0; i < n; i++) {
        const dbe_point_t *p = &points[i];
        printf("%u %u %u %d %.4f %.4f %.4f %.3f %.2f %.2f\n", p->range_bin, p->azimuth_bin,
               p->elevation_bin, p->doppler_bin, p->x, p->y, p->z, p->velocity_mps, p->power_db,
               p->snr_db);
    }
    return 0;
}
