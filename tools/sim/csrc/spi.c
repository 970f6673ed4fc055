/*
 * The SPI port, for a simulated part on its bus (an Ethernet controller).
 *
 * Byte time. simavr 1.6 completes every SPI byte 100 us after the SPDR write, whatever
 * the clock ("should be speed dependent", says its avr_spi.c). On the chip a byte is 8
 * SPI clocks: 8 x the divisor of SPCR's SPR1:0 (fosc/4, /16, /64, /128), halved with
 * SPSR's SPI2X (so 16 CPU cycles at fosc/2). spi_fix_timing adds a second handler of
 * SPDR writes, called by simavr's io write mux after simavr's own: that one has just
 * registered its completion timer (param: the SPI module), which this one moves to the
 * chip's byte time, counted from the end of the writing instruction (OUT: 1 cycle,
 * ST/STS: 2).
 *
 * A part. simavr raises SPI_IRQ_OUTPUT with the byte sent when the byte completes; the
 * part answers by raising SPI_IRQ_INPUT with its own byte, which the next SPDR read
 * returns. The part's chip select is a plain GPIO whose pin IRQ simavr raises when its
 * level changes.
 */
#include <string.h>

#include "sim_cycle_timers.h"
#include "sim_io.h"
#include "sim_irq.h"
#include "sim_regbit.h"
#include "avr_ioport.h"
#include "avr_spi.h"

#include "pins.h"
#include "spi.h"

static avr_spi_t *find_spi(avr_t *avr)
{
	for (avr_io_t *io = avr->io_port; io; io = io->next)
		if (!strcmp(io->kind, "spi"))
			return (avr_spi_t *)io;
	return NULL;
}

/* CPU cycles per SPI byte for the divisor SPCR and SPSR select. */
static avr_cycle_count_t byte_cycles(avr_t *avr, const avr_spi_t *p)
{
	static const avr_cycle_count_t divisor[4] = { 4, 16, 64, 128 };
	int spr = avr_regbit_get(avr, p->spr[0]) | (avr_regbit_get(avr, p->spr[1]) << 1);
	avr_cycle_count_t div = divisor[spr];
	if (avr_regbit_get(avr, p->spr[2]))
		div /= 2;
	return 8 * div;
}

static void spdr_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
	(void)addr;
	(void)v;
	avr_spi_t *p = param;
	for (avr_cycle_timer_slot_p t = avr->cycle_timers.timer; t; t = t->next) {
		if (t->param != p)
			continue;
		avr_cycle_timer_t done = t->timer;
		avr_cycle_timer_cancel(avr, done, p);
		avr_cycle_timer_register(avr, pins_write_end(avr) - avr->cycle + byte_cycles(avr, p), done, p);
		return;
	}
}

int spi_fix_timing(avr_t *avr)
{
	avr_spi_t *p = find_spi(avr);
	if (!p)
		return -1;
	avr_register_io_write(avr, p->r_spdr, spdr_write, p);
	return 0;
}

/* SPI_IRQ_OUTPUT: a byte went out; the part's answer comes back in. */
void spi_part_update_int(spi_part_t *part)
{
	if (!part->fn || !part->drive_int)
		return;
	int level = part->fn(part->ctx, SPI_EVENT_INT, 0, part->avr->cycle);
	if (level < 0 || level == part->int_level)
		return;
	part->int_level = level;
	part->drive_int(part->harness, level);
}

static void part_byte(avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	spi_part_t *part = param;
	int answer = part->fn(part->ctx, SPI_EVENT_BYTE, (uint8_t)value, part->avr->cycle);
	if (answer >= 0)
		avr_raise_irq(part->input, (uint32_t)answer);
	spi_part_update_int(part);
}

static void part_cs(avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	spi_part_t *part = param;
	part->fn(part->ctx, SPI_EVENT_CS, value ? 1 : 0, part->avr->cycle);
	spi_part_update_int(part);
}

int spi_attach_part(avr_t *avr, spi_part_t *part, char port, int bit, spi_part_fn fn, void *ctx)
{
	avr_spi_t *p = find_spi(avr);
	if (!p || bit < 0 || bit > 7)
		return -1;
	avr_irq_t *cs = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(port), bit);
	if (!cs)
		return -1;
	part->avr = avr;
	part->input = p->io.irq + SPI_IRQ_INPUT;
	part->fn = fn;
	part->ctx = ctx;
	part->int_level = -1;
	avr_irq_register_notify(p->io.irq + SPI_IRQ_OUTPUT, part_byte, part);
	avr_irq_register_notify(cs, part_cs, part);
	return 0;
}
