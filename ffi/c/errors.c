/* Every error path of the C API, from C: each call below must fail with its status, change
 * nothing, and leave a working handle working. Prints "ok N checks" and exits 0, or names
 * the first failed check and exits 1. */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "dbe_radar.h"

static _Alignas(DBE_STATE_ALIGN) unsigned char state[DBE_COLORADAR_STATE_BYTES_MAX + 8];
static _Alignas(DBE_CUBE_ALIGN) unsigned char cube[DBE_COLORADAR_CUBE_BYTES + 8];
static int16_t chirp[4 * 128 * 2];
static int checks;

#define EXPECT(call, status)                                                                    \
    do {                                                                                        \
        dbe_status_t got_ = (call);                                                             \
        checks++;                                                                               \
        if (got_ != (status)) {                                                                 \
            printf("line %d: %s gave %s, expected %s\n", __LINE__, #call, dbe_status_name(got_), \
                   dbe_status_name(status));                                                    \
            return 1;                                                                           \
        }                                                                                       \
    } while (0)

#define CHECK(cond)                                                   \
    do {                                                              \
        checks++;                                                     \
        if (!(cond)) {                                                \
            printf("line %d: %s does not hold\n", __LINE__, #cond);  \
            return 1;                                                 \
        }                                                             \
    } while (0)

int main(void) {
    const int P = DBE_PRESET_COLORADAR;
    dbe_sizes_t sz;
    dbe_config_t cfg;
    dbe_t *radar = NULL;
    const char *detail = NULL;
    size_t n;

    /* Sizes and names. */
    EXPECT(dbe_sizes(P, NULL), DBE_ERR_NULL_POINTER);
    EXPECT(dbe_sizes(7, &sz), DBE_ERR_UNKNOWN_PRESET);
    EXPECT(dbe_sizes(P, &sz), DBE_OK);
    CHECK(sz.samples == 128 && sz.loops == 128 && sz.tx == 3 && sz.rx == 4);
    CHECK(sz.state_bytes <= DBE_COLORADAR_STATE_BYTES_MAX && sz.cube_bytes == DBE_COLORADAR_CUBE_BYTES);
    CHECK(sz.state_align <= DBE_STATE_ALIGN && sz.cube_align <= DBE_CUBE_ALIGN);
    CHECK(strcmp(dbe_status_name(DBE_ERR_CHIRP_OUT_OF_ORDER), "DBE_ERR_CHIRP_OUT_OF_ORDER") == 0);
    CHECK(strcmp(dbe_status_name(-3), "DBE_ERR_UNKNOWN") == 0);
    EXPECT(dbe_default_config(9, &cfg), DBE_ERR_UNKNOWN_PRESET);
    EXPECT(dbe_default_config(P, &cfg), DBE_OK);

    /* dbe_init refuses, naming the value, and leaves no handle. */
    EXPECT(dbe_init(P, NULL, sizeof state, cube, sizeof cube, NULL, &radar, &detail), DBE_ERR_NULL_POINTER);
    EXPECT(dbe_init(P, state, sz.state_bytes - 1, cube, sizeof cube, NULL, &radar, &detail), DBE_ERR_BUFFER_TOO_SMALL);
    EXPECT(dbe_init(P, state, sizeof state, cube, sz.cube_bytes - 1, NULL, &radar, &detail), DBE_ERR_BUFFER_TOO_SMALL);
    EXPECT(dbe_init(P, state + 4, sizeof state - 4, cube, sizeof cube, NULL, &radar, &detail), DBE_ERR_MISALIGNED);
    EXPECT(dbe_init(P, state, sizeof state, cube + 1, sizeof cube - 1, NULL, &radar, &detail), DBE_ERR_MISALIGNED);
    EXPECT(dbe_init(5, state, sizeof state, cube, sizeof cube, NULL, &radar, &detail), DBE_ERR_UNKNOWN_PRESET);
    CHECK(radar == NULL);
    dbe_config_t bad = cfg;
    bad.params.loading = NAN;
    EXPECT(dbe_init(P, state, sizeof state, cube, sizeof cube, &bad, &radar, &detail), DBE_ERR_NOT_FINITE);
    CHECK(radar == NULL && detail && strcmp(detail, "params.loading") == 0);
    bad = cfg;
    bad.waveform.start_frequency_hz = 77.0; /* GHz written as Hz */
    EXPECT(dbe_init(P, state, sizeof state, cube, sizeof cube, &bad, &radar, &detail), DBE_ERR_OUT_OF_RANGE);
    CHECK(detail && strcmp(detail, "waveform.start_frequency_hz") == 0);
    bad = cfg;
    bad.antennas.num_tx = 2;
    EXPECT(dbe_init(P, state, sizeof state, cube, sizeof cube, &bad, &radar, &detail), DBE_ERR_ARRAY_SHAPE);
    bad = cfg;
    bad.params.coherent_doppler_bins = -1.0f;
    EXPECT(dbe_init(P, state, sizeof state, cube, sizeof cube, &bad, &radar, &detail), DBE_ERR_OUT_OF_RANGE);
    CHECK(detail && strcmp(detail, "params.coherent_doppler_bins") == 0);
    bad = cfg;
    bad.params.range_window = 42;
    EXPECT(dbe_init(P, state, sizeof state, cube, sizeof cube, &bad, &radar, &detail), DBE_ERR_OUT_OF_RANGE);
    CHECK(detail && strcmp(detail, "params.range_window") == 0);
    bad = cfg;
    bad.antennas.tx[1][0] = 3.0f; /* the azimuth line is no longer uniform */
    EXPECT(dbe_init(P, state, sizeof state, cube, sizeof cube, &bad, &radar, &detail), DBE_ERR_AZIMUTH_NOT_UNIFORM);
    /* The failed init left no handle in the state memory. */
    EXPECT(dbe_begin_frame((dbe_t *)state), DBE_ERR_BAD_HANDLE);
    EXPECT(dbe_begin_frame(NULL), DBE_ERR_NULL_POINTER);

    /* A working handle. */
    EXPECT(dbe_init(P, state, sizeof state, cube, sizeof cube, &cfg, &radar, &detail), DBE_OK);
    CHECK(radar != NULL && detail == NULL);

    /* Chirps: size, alignment, order. */
    EXPECT(dbe_push_chirp(radar, 0, 0, NULL, sz.chirp_values), DBE_ERR_NULL_POINTER);
    EXPECT(dbe_push_chirp(radar, 0, 0, chirp, sz.chirp_values - 1), DBE_ERR_CHIRP_SIZE);
    EXPECT(dbe_push_chirp(radar, 0, 0, (const int16_t *)((const char *)chirp + 1), sz.chirp_values), DBE_ERR_MISALIGNED);
    EXPECT(dbe_push_chirp(radar, 0, 1, chirp, sz.chirp_values), DBE_ERR_CHIRP_OUT_OF_ORDER);
    /* The frame stays an error until it is processed (refused) or restarted. */
    EXPECT(dbe_push_chirp(radar, 0, 0, chirp, sz.chirp_values), DBE_ERR_CHIRP_OUT_OF_ORDER);
    EXPECT(dbe_begin_frame(radar), DBE_OK);
    EXPECT(dbe_push_chirp(radar, 0, 0, chirp, sz.chirp_values), DBE_OK);
    dbe_frame_stats_t st;
    EXPECT(dbe_process_frame(radar, &st), DBE_ERR_FRAME_INCOMPLETE);
    EXPECT(dbe_points(radar, NULL, 0, &n), DBE_OK);
    CHECK(n == 0);

    /* A whole frame of zeros: processed, no points; then a chirp too many. */
    for (uint32_t k = 0; k < sz.loops; k++)
        for (uint32_t t = 0; t < sz.tx; t++)
            EXPECT(dbe_push_chirp(radar, (uint16_t)k, (uint8_t)t, chirp, sz.chirp_values), DBE_OK);
    EXPECT(dbe_push_chirp(radar, 0, 0, chirp, sz.chirp_values), DBE_ERR_TOO_MANY_CHIRPS);
    EXPECT(dbe_process_frame(radar, NULL), DBE_ERR_TOO_MANY_CHIRPS);
    for (uint32_t k = 0; k < sz.loops; k++)
        for (uint32_t t = 0; t < sz.tx; t++)
            EXPECT(dbe_push_chirp(radar, (uint16_t)k, (uint8_t)t, chirp, sz.chirp_values), DBE_OK);
    EXPECT(dbe_process_frame(radar, &st), DBE_OK);
    EXPECT(dbe_points(radar, NULL, 0, &n), DBE_OK);
    CHECK(n == 0 && st.points == 0);
    EXPECT(dbe_points(radar, NULL, 4, &n), DBE_ERR_NULL_POINTER);
    EXPECT(dbe_points(radar, NULL, 0, NULL), DBE_ERR_NULL_POINTER);
    dbe_ego_t ego;
    EXPECT(dbe_ego_velocity(radar, NULL), DBE_ERR_NULL_POINTER);
    EXPECT(dbe_ego_velocity(radar, &ego), DBE_OK);
    CHECK(ego.status == DBE_EGO_TOO_FEW_POINTS && ego.points == 0);

    /* Coupling: a table longer than the range bins is refused, one of them accepted. */
    static float coupling[3 * 4 * 129 * 2];
    EXPECT(dbe_set_coupling(radar, coupling, 3 * 4 * 129 * 2), DBE_ERR_OUT_OF_RANGE);
    EXPECT(dbe_set_coupling(radar, coupling, 3 * 4 * 7), DBE_ERR_OUT_OF_RANGE);
    EXPECT(dbe_set_coupling(radar, NULL, 8), DBE_ERR_NULL_POINTER);
    coupling[5] = INFINITY;
    EXPECT(dbe_set_coupling(radar, coupling, 3 * 4 * 128 * 2), DBE_ERR_NOT_FINITE);
    coupling[5] = 0.0f;
    EXPECT(dbe_set_coupling(radar, coupling, 3 * 4 * 128 * 2), DBE_OK);

    /* Channel gains: one complex factor per channel, finite and non-zero; none removes them. */
    float gains[3 * 4 * 2];
    for (int i = 0; i < 3 * 4; i++) {
        gains[2 * i] = 1.0f;
        gains[2 * i + 1] = 0.0f;
    }
    EXPECT(dbe_set_channel_gains(radar, gains, 3 * 4 * 2 - 2), DBE_ERR_OUT_OF_RANGE);
    EXPECT(dbe_set_channel_gains(radar, NULL, 3 * 4 * 2), DBE_ERR_NULL_POINTER);
    gains[6] = NAN;
    EXPECT(dbe_set_channel_gains(radar, gains, 3 * 4 * 2), DBE_ERR_NOT_FINITE);
    gains[6] = 0.0f;
    EXPECT(dbe_set_channel_gains(radar, gains, 3 * 4 * 2), DBE_ERR_OUT_OF_RANGE);
    gains[7] = -0.5f;
    EXPECT(dbe_set_channel_gains(radar, gains, 3 * 4 * 2), DBE_OK);
    EXPECT(dbe_set_channel_gains(radar, NULL, 0), DBE_OK);

    /* Range spectra (an FFT accelerator's): size, alignment, order as for chirps; a frame of
     * zero spectra, and one of NaN spectra, are processed without points. */
    static float spectra[4 * 128 * 2];
    EXPECT(dbe_begin_frame(radar), DBE_OK);
    EXPECT(dbe_push_range_spectra(radar, 0, 0, NULL, sz.chirp_values), DBE_ERR_NULL_POINTER);
    EXPECT(dbe_push_range_spectra(radar, 0, 0, spectra, sz.chirp_values + 1), DBE_ERR_CHIRP_SIZE);
    EXPECT(dbe_push_range_spectra(radar, 0, 0, (const float *)((const char *)spectra + 2), sz.chirp_values),
           DBE_ERR_MISALIGNED);
    EXPECT(dbe_push_range_spectra(radar, 1, 0, spectra, sz.chirp_values), DBE_ERR_CHIRP_OUT_OF_ORDER);
    EXPECT(dbe_begin_frame(radar), DBE_OK);
    for (int pass = 0; pass < 2; pass++) {
        for (uint32_t k = 0; k < sz.loops; k++)
            for (uint32_t t = 0; t < sz.tx; t++)
                EXPECT(dbe_push_range_spectra(radar, (uint16_t)k, (uint8_t)t, spectra, sz.chirp_values), DBE_OK);
        EXPECT(dbe_push_range_spectra(radar, 0, 0, spectra, sz.chirp_values), DBE_ERR_TOO_MANY_CHIRPS);
        EXPECT(dbe_begin_frame(radar), DBE_OK);
        for (uint32_t k = 0; k < sz.loops; k++)
            for (uint32_t t = 0; t < sz.tx; t++)
                EXPECT(dbe_push_range_spectra(radar, (uint16_t)k, (uint8_t)t, spectra, sz.chirp_values), DBE_OK);
        EXPECT(dbe_process_frame(radar, &st), DBE_OK);
        CHECK(st.points == 0);
        for (size_t i = 0; i < sizeof spectra / sizeof spectra[0]; i++)
            spectra[i] = NAN;
    }

    /* 16-bit range spectra with an exponent per RX channel: sizes, pointers, exponent range
     * (a rejected call stores nothing: the frame still starts at loop 0 slot 0), order; a
     * frame of zero blocks gives no point, one of extreme mantissas at the largest exponent
     * is processed. */
    static int16_t blocks[4 * 128 * 2];
    int8_t exps[4] = {0, 0, 0, 0};
    EXPECT(dbe_begin_frame(radar), DBE_OK);
    EXPECT(dbe_push_range_blocks(radar, 0, 0, NULL, sz.chirp_values, exps, 4), DBE_ERR_NULL_POINTER);
    EXPECT(dbe_push_range_blocks(radar, 0, 0, blocks, sz.chirp_values, NULL, 4), DBE_ERR_NULL_POINTER);
    EXPECT(dbe_push_range_blocks(radar, 0, 0, blocks, sz.chirp_values - 2, exps, 4), DBE_ERR_CHIRP_SIZE);
    EXPECT(dbe_push_range_blocks(radar, 0, 0, blocks, sz.chirp_values, exps, 3), DBE_ERR_CHIRP_SIZE);
    EXPECT(dbe_push_range_blocks(radar, 0, 0, (const int16_t *)((const char *)blocks + 1), sz.chirp_values, exps, 4),
           DBE_ERR_MISALIGNED);
    exps[2] = 113;
    EXPECT(dbe_push_range_blocks(radar, 0, 0, blocks, sz.chirp_values, exps, 4), DBE_ERR_OUT_OF_RANGE);
    exps[2] = -126;
    EXPECT(dbe_push_range_blocks(radar, 0, 0, blocks, sz.chirp_values, exps, 4), DBE_ERR_OUT_OF_RANGE);
    exps[2] = 0;
    EXPECT(dbe_push_range_blocks(radar, 1, 0, blocks, sz.chirp_values, exps, 4), DBE_ERR_CHIRP_OUT_OF_ORDER);
    for (int pass = 0; pass < 2; pass++) {
        EXPECT(dbe_begin_frame(radar), DBE_OK);
        for (uint32_t k = 0; k < sz.loops; k++)
            for (uint32_t t = 0; t < sz.tx; t++)
                EXPECT(dbe_push_range_blocks(radar, (uint16_t)k, (uint8_t)t, blocks, sz.chirp_values, exps, 4), DBE_OK);
        EXPECT(dbe_push_range_blocks(radar, 0, 0, blocks, sz.chirp_values, exps, 4), DBE_ERR_TOO_MANY_CHIRPS);
        EXPECT(dbe_begin_frame(radar), DBE_OK);
        for (uint32_t k = 0; k < sz.loops; k++)
            for (uint32_t t = 0; t < sz.tx; t++)
                EXPECT(dbe_push_range_blocks(radar, (uint16_t)k, (uint8_t)t, blocks, sz.chirp_values, exps, 4), DBE_OK);
        EXPECT(dbe_process_frame(radar, &st), DBE_OK);
        if (pass == 0) CHECK(st.points == 0);
        for (size_t i = 0; i < sizeof blocks / sizeof blocks[0]; i++)
            blocks[i] = (i % 2) ? INT16_MAX : INT16_MIN;
        for (int r = 0; r < 4; r++)
            exps[r] = 112;
    }

    /* Range bias: any finite value. */
    EXPECT(dbe_set_range_bias(radar, NAN), DBE_ERR_NOT_FINITE);
    EXPECT(dbe_set_range_bias(radar, 0.07f), DBE_OK);
    EXPECT(dbe_set_range_bias(NULL, 0.07f), DBE_ERR_NULL_POINTER);

    printf("ok %d checks\n", checks);
    return 0;
}
