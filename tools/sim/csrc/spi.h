/*
 * The SPI port's byte time and a part on its bus (csrc/spi.c).
 */
#ifndef UNO_SPI_H
#define UNO_SPI_H

#include <stdint.h>

#include "sim_avr.h"

/* A part's answer to one event: the byte it shifts out on MISO (0..255), or -1 for none. */
typedef int (*spi_part_fn)(void *ctx, int event, uint8_t value, uint64_t cycle);

/* spi_part_fn's events: a byte exchanged (value: MOSI), the chip select changed (value: its level). */
#define SPI_EVENT_BYTE 0
#define SPI_EVENT_CS 1
/* The part's INT line: the answer is its level (0 low, 1 high), or -1 when it has none. Asked
 * after each chip-select change and each byte, and by the harness between runs. */
#define SPI_EVENT_INT 2

/* Times every SPI byte as the chip does (8 SPI clocks), instead of simavr 1.6's 100 us.
 * 0, or -1 if the core has no SPI port. */
int spi_fix_timing(avr_t *avr);

/* A part on the bus; its storage must last as long as the core (simavr keeps pointers to it). */
/* Drives the part's INT line onto its pin (the harness's, which knows the pins). */
typedef void (*spi_int_fn)(void *harness, int level);

typedef struct spi_part {
	avr_t *avr;
	struct avr_irq_t *input;
	spi_part_fn fn;
	void *ctx;
	/* The INT line, if wired: who drives it, and the level last driven (-1: not yet). */
	spi_int_fn drive_int;
	void *harness;
	int int_level;
} spi_part_t;

/* Drives the part's INT line to the level it reports now, if wired and changed. */
void spi_part_update_int(spi_part_t *part);

/* Attaches `part` to the SPI port, its chip select on pin P`port``bit`: `fn` is called with
 * every byte the master sends (its answer becomes SPDR's next read) and every change of the
 * chip select. 0, or -1 if the core lacks the SPI port or the pin. */
int spi_attach_part(avr_t *avr, spi_part_t *part, char port, int bit, spi_part_fn fn, void *ctx);

#endif
