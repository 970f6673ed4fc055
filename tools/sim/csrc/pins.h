/*
 * Pins as the outside world sees them (csrc/pins.c): levels driven from outside, now or at a
 * scheduled cycle; the level an output shows (PORTx, or a timer's compare output); a log of
 * an output's level changes.
 */
#ifndef UNO_PINS_H
#define UNO_PINS_H

#include <stddef.h>
#include <stdint.h>

#include "sim_avr.h"
#include "avr_ioport.h"

/* ports 'A'..'L' */
#define PINS_PORTS 12
/* pins whose output can be logged at once */
#define PINS_LOGGED 16

/* pins_* results */
#define PINS_OK 0
#define PINS_ERR_ARG (-1)  /* no such pin, or a bad level */
#define PINS_ERR_PAST (-2) /* a cycle already gone */
#define PINS_ERR_NOMEM (-3)

/* One level change of a logged output. Must match `PinEdgeRaw` in src/ffi.rs. */
typedef struct pin_edge {
	uint64_t cycle;
	uint8_t level;
} pin_edge_t;

/* A level to drive a pin to from outside at cycle `at` (-1: release it). */
typedef struct pin_change {
	uint64_t at;
	char port;
	uint8_t bit;
	int8_t level;
} pin_change_t;

/* The level changes of one output pin, while it is an output. */
typedef struct pin_log {
	char port;
	uint8_t bit;
	uint8_t level; /* the last level logged (at first: the pin's level when the log began) */
	pin_edge_t *edges;
	size_t len, cap;
} pin_log_t;

struct pins;

/* One port: simavr's handlers of its registers, which pins.c wraps, and what drives its pins. */
typedef struct pin_port {
	struct pins *pins;
	avr_ioport_t *io; /* NULL: the chip has no such port */
	avr_io_write_t port_write, ddr_write;
	void *port_param, *ddr_param;
	avr_io_read_t pin_read;
	void *pin_param;
	uint8_t ext_mask, ext_value; /* inputs driven from outside, and their levels */
	uint8_t oc_mask, oc_level;   /* pins a timer's compare output owns (COMnx != 0), their levels */
	uint8_t logged;              /* pins whose output is logged */
} pin_port_t;

typedef struct pins {
	avr_t *avr;
	pin_port_t port[PINS_PORTS];
	/* The exact cycle of the pin change being made now (PINS_NOW: avr->cycle). */
	uint64_t change_cycle;
	/* Levels scheduled from outside, in time order (ties: in the order given). */
	pin_change_t *queue;
	size_t head, len, cap;
	pin_log_t log[PINS_LOGGED];
	int logs;
} pins_t;

#define PINS_NOW UINT64_MAX

/* Finds the chip's ports and wraps their registers' handlers. After avr_init. */
void pins_init(pins_t *p, avr_t *avr);
/* After avr_reset: pins at 0 as PINx now reads, the outside levels driven again, the schedule
 * going on (the outside world does not reset with the chip). */
void pins_after_reset(pins_t *p);
void pins_free(pins_t *p);

/* The cycle at which a register write by the instruction now executing lands: its end (OUT
 * takes 1 cycle; SBI, CBI, ST and STS take 2). */
uint64_t pins_write_end(avr_t *avr);
/* The exact cycle of the pin change being made now: a scheduled level's cycle, the end of the
 * instruction writing a port, a compare match's cycle; else the current cycle. */
uint64_t pins_change_cycle(const pins_t *p);

/* simavr's port `port`, or NULL. */
avr_ioport_t *pins_port(const pins_t *p, char port);
/* The port and bit of the pin `bit` (a PORTx/DDRx/PINx register bit) names; 0, or -1 if none. */
int pins_of_regbit(const pins_t *p, avr_regbit_t bit, char *port, int *pin);

/* Drives pin P`port``bit` from outside to `level` (0/1), or releases it (-1), now. An output
 * keeps showing what the chip drives; the outside level shows once it is an input. */
int pins_drive(pins_t *p, char port, int bit, int level);
/* The same at cycle `at` (not in the past), by a cycle timer. */
int pins_schedule(pins_t *p, char port, int bit, uint64_t at, int level);
/* Levels scheduled that have not been applied yet. */
size_t pins_scheduled(const pins_t *p);

/* A timer's compare unit owns pin P`port``bit` (`connected`: COMnx != 0) and shows `level`
 * on it (where it is an output) from cycle `at`. */
void pins_compare_output(pins_t *p, char port, int bit, int connected, int level, uint64_t at);
/* The level pin P`port``bit` shows: an output's as its IRQ carries it to PCINT and to parts on
 * the pin (PORTx or the compare output), an input's PINx. -1 if there is no such pin. */
int pins_level(const pins_t *p, char port, int bit);

/* Logs pin P`port``bit`'s level changes while it is an output; stores the level now. */
int pins_log(pins_t *p, char port, int bit, int *level);
/* Moves up to `max` logged changes (oldest first) to `out`: how many, or PINS_ERR_ARG if the
 * pin is not logged. */
long pins_take_log(pins_t *p, char port, int bit, pin_edge_t *out, size_t max);

#endif
