/* postcapture FMU runtime: types shared by the generated model data and the runtime. */
#ifndef PC_TYPES_H
#define PC_TYPES_H

#define PC_TWO_PI (2.0 * 3.141592653589793) /* Python's 2 * math.pi */

enum { PC_PROFILE_STEP = 0, PC_PROFILE_SINE = 1, PC_PROFILE_CHIRP = 2, PC_PROFILE_TABLE = 3 };

/* One excitation profile on one input channel, active on [start, stop). */
typedef struct {
    int kind;
    int channel;    /* index in u = [F_B (3), tau_B (3), tau_arm (n_arm)] */
    double start;   /* s */
    double stop;    /* s, INFINITY when open-ended */
    double a;       /* amplitude */
    double rise;    /* step: ramp time (s) */
    double w;       /* sine: 2 pi f (rad/s) */
    double phase;   /* rad */
    double offset;  /* sine offset */
    double f0;      /* chirp: start frequency (Hz) */
    double rate;    /* chirp: (f1 - f0) / (stop - start) (Hz/s) */
    int table;      /* table: offset in PC_TABLE_T / PC_TABLE_V */
    int n_table;    /* table: number of points */
} pc_profile_t;

#endif
