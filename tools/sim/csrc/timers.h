/*
 * simavr 1.6's timers corrected where a serial line built on a timer sees the difference
 * (csrc/timers.c): the compare output units, the input capture units, the 16-bit registers'
 * TEMP.
 */
#ifndef UNO_TIMERS_H
#define UNO_TIMERS_H

#include <stdint.h>

#include "sim_avr.h"
#include "avr_timer.h"

#include "pins.h"

/* Timer0..Timer5 */
#define TIMERS 6
/* Edges on an input capture pin still in its synchronizer (a few cycles' worth). */
#define CAPTURE_EDGES 16
/* 16-bit registers of a timer read or written through TEMP: TCNTn, ICRn, OCRnA..C. */
#define WIDE_REGS 5

struct timer_unit;

/* A compare unit with an output pin, and its OCnx latch. */
typedef struct timer_oc {
	struct timer_unit *unit;
	int comp; /* AVR_TIMER_COMPA.. */
	char port;
	int bit;
	uint8_t latch;
} timer_oc_t;

/* An edge on an input capture pin, on its way through the synchronizer (and the noise
 * canceller): it reaches the edge detector at `due`. */
typedef struct capture_edge {
	uint64_t at, due;
	uint8_t level, noise_canceller;
} capture_edge_t;

/* An input capture unit: the pin's level as last seen, the level past the synchronizer and
 * noise canceller, the edges in between. */
typedef struct timer_icp {
	struct timer_unit *unit;
	avr_irq_t *pin;
	uint8_t raw, filtered;
	capture_edge_t edge[CAPTURE_EDGES];
	unsigned head, len;
} timer_icp_t;

/* A 16-bit register's low byte, whose access goes through the timer's TEMP register, and
 * simavr's own handlers of it. */
typedef struct wide_reg {
	struct timer_unit *unit;
	avr_io_addr_t low, high;
	avr_io_write_t write;
	void *write_param;
	avr_io_read_t read;
	void *read_param;
} wide_reg_t;

/* A register's handler, kept to be called before ours. */
typedef struct io_write {
	avr_io_addr_t addr;
	avr_io_write_t c;
	void *param;
} io_write_t;

typedef struct timer_unit {
	struct timers *timers;
	avr_timer_t *timer;
	timer_oc_t oc[AVR_TIMER_COMP_COUNT];
	int ocs;
	io_write_t control[2]; /* simavr's handlers of TCCRnA and TCCRnB */
	timer_icp_t icp;
	int has_icp;
	uint8_t temp;
	wide_reg_t wide[WIDE_REGS];
	int wides;
} timer_unit_t;

typedef struct timers {
	avr_t *avr;
	pins_t *pins;
	timer_unit_t unit[TIMERS];
	int units;
} timers_t;

/* Takes over the chip's timers' compare outputs, input captures and TEMP. After pins_init. */
void timers_init(timers_t *t, avr_t *avr, pins_t *pins);
/* After avr_reset (and pins_after_reset): simavr has linked its timers to the pins again. */
void timers_after_reset(timers_t *t);

#endif
