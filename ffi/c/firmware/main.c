/* The DBE chain from C on a Cortex-M4F (QEMU mps2-an386), linked against the Rust static
 * library: the Rust firmware's embedded frame in, its output lines out (format:
 * firmware/src/lib.rs; H, P, V, F and E lines), so the two can be compared point by point.
 * Build and run: `cargo xtask c-firmware [coloradar|iwr6843]`. */
#include <stdarg.h>
#include <stdio.h>
#include "dbe_radar.h"
#include "semihost.h"

#if defined(DBE_C_IWR6843)
#define PRESET DBE_PRESET_IWR6843
#define NAME "iwr6843"
#define STATE_BYTES DBE_IWR6843_STATE_BYTES_MAX
#define CUBE_BYTES DBE_IWR6843_CUBE_BYTES
#else
#define PRESET DBE_PRESET_COLORADAR
#define NAME "coloradar"
#define STATE_BYTES DBE_COLORADAR_STATE_BYTES_MAX
#define CUBE_BYTES DBE_COLORADAR_CUBE_BYTES
#endif

extern const int16_t dbe_frame[];
extern const unsigned char dbe_frame_end[];

/* The firmware decides where everything lives: here, .bss. */
static _Alignas(DBE_STATE_ALIGN) unsigned char state[STATE_BYTES];
static _Alignas(DBE_CUBE_ALIGN) unsigned char cube[CUBE_BYTES];
static dbe_point_t points[256];

static void say(const char *fmt, ...) {
    char line[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    sh_write0(line);
}

static int fail(const char *what, dbe_status_t s, const char *detail) {
    say("X %s: %s %s\n", what, dbe_status_name(s), detail ? detail : "");
    return 1;
}

int main(void) {
    dbe_sizes_t sz;
    dbe_t *radar;
    const char *detail = NULL;
    dbe_status_t s = dbe_sizes(PRESET, &sz);
    if (s != DBE_OK) return fail("dbe_sizes", s, NULL);
    size_t frame_values = (size_t)(dbe_frame_end - (const unsigned char *)dbe_frame) / 2;
    if (frame_values != (size_t)sz.chirp_values * sz.chirps_per_frame) {
        say("X embedded frame has %u int16, the preset needs %u\n", (unsigned)frame_values,
            (unsigned)(sz.chirp_values * sz.chirps_per_frame));
        return 1;
    }
    s = dbe_init(PRESET, state, sizeof state, cube, sizeof cube, NULL, &radar, &detail);
    if (s != DBE_OK) return fail("dbe_init", s, detail);

    /* As a DMA would deliver them: chirp after chirp in TDM order. */
    for (uint32_t k = 0; k < sz.loops; k++) {
        for (uint32_t t = 0; t < sz.tx; t++) {
            const int16_t *iq = dbe_frame + ((size_t)k * sz.tx + t) * sz.chirp_values;
            s = dbe_push_chirp(radar, (uint16_t)k, (uint8_t)t, iq, sz.chirp_values);
            if (s != DBE_OK) return fail("dbe_push_chirp", s, NULL);
        }
    }
    dbe_frame_stats_t st;
    s = dbe_process_frame(radar, &st);
    if (s != DBE_OK) return fail("dbe_process_frame", s, NULL);
    size_t n;
    s = dbe_points(radar, points, sizeof points / sizeof points[0], &n);
    if (s != DBE_OK) return fail("dbe_points", s, NULL);
    dbe_ego_t ego;
    s = dbe_ego_velocity(radar, &ego);
    if (s != DBE_OK) return fail("dbe_ego_velocity", s, NULL);

    say("H preset %s chain dbe samples %u loops %u tx %u rx %u azimuth_bins %u elevation_bins %u c-api %s\n",
        NAME, (unsigned)sz.samples, (unsigned)sz.loops, (unsigned)sz.tx, (unsigned)sz.rx,
        (unsigned)sz.azimuth_bins, (unsigned)sz.elevation_bins, dbe_version());
    /* %.9g: nine significant digits give every float back exactly. */
    for (size_t i = 0; i < n && i < sizeof points / sizeof points[0]; i++) {
        const dbe_point_t *p = &points[i];
        say("P %u %u %u %d %.9g %.9g %.9g %.9g %.9g %.9g\n", p->range_bin, p->azimuth_bin,
            p->elevation_bin, p->doppler_bin, (double)p->x, (double)p->y, (double)p->z,
            (double)p->velocity_mps, (double)p->power_db, (double)p->snr_db);
    }
    static const char *const ego_status[] = {"ok", "standstill", "too_few_points", "ill_conditioned"};
    say("V %.9g %.9g %.9g %u %u %s\n", (double)ego.velocity[0], (double)ego.velocity[1],
        (double)ego.velocity[2], ego.inliers, ego.points,
        ego.status < 4 ? ego_status[ego.status] : "?");
    say("F %u %u %u %u %u %u %u\n", st.detections, st.detection_overflow, st.points,
        st.point_overflow, st.skipped_range_bins, st.detections_without_point,
        st.doppler_rejected);
    say("E ok\n");
    return 0;
}
