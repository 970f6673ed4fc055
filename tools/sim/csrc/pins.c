/*
 * Pins as the outside world sees them.
 *
 * Outside levels. A pin driven from outside (a switch, a serial line) is an input whose level
 * simavr's port takes from its "external" state, raised on the pin's IRQ. A scheduled level is
 * applied by a cycle timer at its cycle, and the change carries that cycle exactly
 * (pins_change_cycle), though the CPU sees it at the next instruction boundary: an input
 * capture unit stamps the edge from its own cycle, not from the instruction's.
 *
 * What an output shows. simavr 1.6 shows PORTx on an output and lets a timer's compare output
 * raise the pin's IRQ beside it: any later PORTx or DDRx write puts PORTx back on the pin, a
 * PINx read returns PORTx, and the compare output reaches the pin even while it is an input.
 * On the chip (ATmega328P datasheet, "Compare Match Output Unit") the compare output replaces
 * PORTx on the pin while COMnx1:0 is not zero, and only shows where DDRx makes the pin an
 * output. Here every port's PORTx, DDRx and PINx handlers are wrapped: simavr's own run with
 * PORTx's bits owned by a compare output replaced by that output's levels (and PORTx as written
 * restored after), so the pin's IRQ, PINx and pin-change interrupts see what the pin shows.
 *
 * The log. Each level change of a logged pin while it is an output, at its exact cycle: the
 * end of the instruction writing PORTx, DDRx or PINx, or the compare match's cycle.
 */
#include <stdlib.h>
#include <string.h>

#include "sim_cycle_timers.h"
#include "sim_io.h"
#include "sim_irq.h"

#include "pins.h"

static pin_port_t *port_at(pins_t *p, char port)
{
	int i = port - 'A';
	return i >= 0 && i < PINS_PORTS && p->port[i].io ? &p->port[i] : NULL;
}

static const pin_port_t *port_at_const(const pins_t *p, char port)
{
	int i = port - 'A';
	return i >= 0 && i < PINS_PORTS && p->port[i].io ? &p->port[i] : NULL;
}

avr_ioport_t *pins_port(const pins_t *p, char port)
{
	const pin_port_t *pp = port_at_const(p, port);
	return pp ? pp->io : NULL;
}

int pins_of_regbit(const pins_t *p, avr_regbit_t bit, char *port, int *pin)
{
	for (int i = 0; i < PINS_PORTS; i++) {
		const avr_ioport_t *io = p->port[i].io;
		if (io && bit.reg && (bit.reg == io->r_port || bit.reg == io->r_ddr || bit.reg == io->r_pin)) {
			*port = (char)('A' + i);
			*pin = bit.bit;
			return 0;
		}
	}
	return -1;
}

uint64_t pins_write_end(avr_t *avr)
{
	uint16_t opcode = (uint16_t)(avr->flash[avr->pc] | (avr->flash[avr->pc + 1] << 8));
	return avr->cycle + ((opcode & 0xF800) == 0xB800 ? 1 : 2);
}

uint64_t pins_change_cycle(const pins_t *p)
{
	return p->change_cycle == PINS_NOW ? p->avr->cycle : p->change_cycle;
}

/* The level output `bit` of port `pp` shows: the compare output's, if one owns it, else PORTx's. */
static int output_level(const pin_port_t *pp, int bit)
{
	uint8_t m = (uint8_t)(1 << bit);
	if (pp->oc_mask & m)
		return (pp->oc_level & m) != 0;
	return (pp->pins->avr->data[pp->io->r_port] & m) != 0;
}

/* PORTx as the pins show it: the bits of outputs a compare output owns replaced by its levels. */
static uint8_t shown_port(const pin_port_t *pp, uint8_t port, uint8_t ddr)
{
	uint8_t owned = pp->oc_mask & ddr;
	return (uint8_t)((port & ~owned) | (pp->oc_level & owned));
}

static void log_push(pin_log_t *l, uint64_t cycle, uint8_t level)
{
	if (l->len && cycle < l->edges[l->len - 1].cycle)
		cycle = l->edges[l->len - 1].cycle; /* a DDRx write and a compare match in one instruction */
	if (l->len == l->cap) {
		size_t cap = l->cap ? l->cap * 2 : 256;
		pin_edge_t *n = realloc(l->edges, cap * sizeof(*n));
		if (!n)
			return;
		l->edges = n;
		l->cap = cap;
	}
	l->edges[l->len++] = (pin_edge_t){ .cycle = cycle, .level = level };
	l->level = level;
}

/* Logs the logged outputs of port `pp` whose level changed, at `cycle`. */
static void log_outputs(pin_port_t *pp, uint64_t cycle)
{
	pins_t *p = pp->pins;
	uint8_t outputs = pp->logged & p->avr->data[pp->io->r_ddr];
	if (!outputs)
		return;
	for (int i = 0; i < p->logs; i++) {
		pin_log_t *l = &p->log[i];
		if (&p->port[l->port - 'A'] != pp || !(outputs & (1 << l->bit)))
			continue;
		uint8_t level = (uint8_t)output_level(pp, l->bit);
		if (level != l->level)
			log_push(l, cycle, level);
	}
}

/* PORTx := `v` (as written), through simavr's handler with the compare outputs shown. */
static void write_port_value(pin_port_t *pp, uint8_t v)
{
	avr_t *avr = pp->pins->avr;
	avr_io_addr_t r_port = pp->io->r_port;
	pp->port_write(avr, r_port, shown_port(pp, v, avr->data[pp->io->r_ddr]), pp->port_param);
	avr->data[r_port] = v;
}

/* PORTx or PINx written (writing ones to PINx toggles those PORTx bits, whatever DDRx says). */
static void port_reg_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
	pin_port_t *pp = param;
	pins_t *p = pp->pins;
	uint64_t at = pins_write_end(avr);
	if (addr == pp->io->r_pin)
		v ^= avr->data[pp->io->r_port];
	p->change_cycle = at;
	write_port_value(pp, v);
	p->change_cycle = PINS_NOW;
	log_outputs(pp, at);
}

static void ddr_reg_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
	pin_port_t *pp = param;
	pins_t *p = pp->pins;
	uint64_t at = pins_write_end(avr);
	avr_io_addr_t r_port = pp->io->r_port;
	uint8_t port = avr->data[r_port];
	p->change_cycle = at;
	avr->data[r_port] = shown_port(pp, port, v);
	pp->ddr_write(avr, addr, v, pp->ddr_param);
	avr->data[r_port] = port;
	p->change_cycle = PINS_NOW;
	log_outputs(pp, at);
}

static uint8_t pin_reg_read(avr_t *avr, avr_io_addr_t addr, void *param)
{
	pin_port_t *pp = param;
	uint8_t v = pp->pin_read(avr, addr, pp->pin_param);
	return shown_port(pp, v, avr->data[pp->io->r_ddr]);
}

void pins_init(pins_t *p, avr_t *avr)
{
	memset(p, 0, sizeof(*p));
	p->avr = avr;
	p->change_cycle = PINS_NOW;
	for (avr_io_t *io = avr->io_port; io; io = io->next) {
		if (strcmp(io->kind, "port"))
			continue;
		avr_ioport_t *port = (avr_ioport_t *)io;
		int i = port->name - 'A';
		if (i < 0 || i >= PINS_PORTS)
			continue;
		pin_port_t *pp = &p->port[i];
		pp->pins = p;
		pp->io = port;
		/* simavr's handlers, kept and replaced (a read handler cannot be chained) */
		avr_io_addr_t a_port = AVR_DATA_TO_IO(port->r_port), a_ddr = AVR_DATA_TO_IO(port->r_ddr),
			      a_pin = AVR_DATA_TO_IO(port->r_pin);
		pp->port_write = avr->io[a_port].w.c;
		pp->port_param = avr->io[a_port].w.param;
		pp->ddr_write = avr->io[a_ddr].w.c;
		pp->ddr_param = avr->io[a_ddr].w.param;
		pp->pin_read = avr->io[a_pin].r.c;
		pp->pin_param = avr->io[a_pin].r.param;
		avr->io[a_port].w.c = port_reg_write;
		avr->io[a_port].w.param = pp;
		avr->io[a_pin].w.c = port_reg_write;
		avr->io[a_pin].w.param = pp;
		avr->io[a_ddr].w.c = ddr_reg_write;
		avr->io[a_ddr].w.param = pp;
		avr->io[a_pin].r.c = pin_reg_read;
		avr->io[a_pin].r.param = pp;
	}
}

void pins_free(pins_t *p)
{
	free(p->queue);
	for (int i = 0; i < p->logs; i++)
		free(p->log[i].edges);
}

size_t pins_scheduled(const pins_t *p)
{
	return p->len - p->head;
}

int pins_drive(pins_t *p, char port, int bit, int level)
{
	pin_port_t *pp = port_at(p, port);
	if (!pp || bit < 0 || bit > 7 || level < -1 || level > 1)
		return PINS_ERR_ARG;
	avr_t *avr = p->avr;
	uint8_t m = (uint8_t)(1 << bit);
	if (level < 0) {
		pp->ext_mask &= (uint8_t)~m;
	} else {
		pp->ext_mask |= m;
		pp->ext_value = (uint8_t)((pp->ext_value & ~m) | (level ? m : 0));
	}
	avr_ioport_external_t e = { .name = (unsigned long)port, .mask = pp->ext_mask, .value = pp->ext_value };
	avr_ioctl(avr, AVR_IOCTL_IOPORT_SET_EXTERNAL(port), &e);
	if (avr->data[pp->io->r_ddr] & m)
		return PINS_OK; /* an output: it shows what the chip drives */
	/* released: an input with its pull-up on reads high, a floating one low */
	int shown = level >= 0 ? level : (avr->data[pp->io->r_port] & m) != 0;
	avr_raise_irq(pp->io->io.irq + bit, (uint32_t)shown);
	return PINS_OK;
}

static avr_cycle_count_t schedule_due(avr_t *avr, avr_cycle_count_t when, void *param)
{
	(void)avr;
	pins_t *p = param;
	while (p->head < p->len && p->queue[p->head].at <= when) {
		pin_change_t c = p->queue[p->head++];
		p->change_cycle = c.at;
		pins_drive(p, c.port, c.bit, c.level);
		p->change_cycle = PINS_NOW;
	}
	if (p->head == p->len) {
		p->head = p->len = 0;
		return 0;
	}
	return p->queue[p->head].at;
}

static void schedule_arm(pins_t *p)
{
	avr_t *avr = p->avr;
	if (p->head == p->len)
		return;
	uint64_t at = p->queue[p->head].at;
	avr_cycle_timer_register(avr, at > avr->cycle ? at - avr->cycle : 0, schedule_due, p);
}

int pins_schedule(pins_t *p, char port, int bit, uint64_t at, int level)
{
	if (!port_at(p, port) || bit < 0 || bit > 7 || level < -1 || level > 1)
		return PINS_ERR_ARG;
	if (at < p->avr->cycle)
		return PINS_ERR_PAST;
	if (p->len == p->cap) {
		if (p->head > 0) {
			memmove(p->queue, p->queue + p->head, (p->len - p->head) * sizeof(*p->queue));
			p->len -= p->head;
			p->head = 0;
		} else {
			size_t cap = p->cap ? p->cap * 2 : 1024;
			pin_change_t *n = realloc(p->queue, cap * sizeof(*n));
			if (!n)
				return PINS_ERR_NOMEM;
			p->queue = n;
			p->cap = cap;
		}
	}
	/* after every change due at or before `at`: usually the end */
	size_t i = p->len;
	while (i > p->head && p->queue[i - 1].at > at)
		i--;
	memmove(p->queue + i + 1, p->queue + i, (p->len - i) * sizeof(*p->queue));
	p->queue[i] = (pin_change_t){ .at = at, .port = port, .bit = (uint8_t)bit, .level = (int8_t)level };
	p->len++;
	if (i == p->head)
		schedule_arm(p);
	return PINS_OK;
}

void pins_after_reset(pins_t *p)
{
	for (int i = 0; i < PINS_PORTS; i++) {
		pin_port_t *pp = &p->port[i];
		if (!pp->io)
			continue;
		pp->oc_mask = pp->oc_level = 0;
		/* avr_reset zeroes PINx but leaves the pin IRQs at their old levels, and simavr
		 * passes on only a change of level: a pull-up switched on again would never reach
		 * PINx. Start every pin IRQ at 0, as PINx now reads, then drive the pins driven
		 * from outside again. */
		for (int bit = 0; bit < 8; bit++)
			pp->io->io.irq[bit].value = 0;
		for (int bit = 0; bit < 8; bit++)
			if (pp->ext_mask & (1 << bit))
				avr_raise_irq(pp->io->io.irq + bit, (pp->ext_value >> bit) & 1);
	}
	schedule_arm(p); /* avr_reset dropped every cycle timer */
}

void pins_compare_output(pins_t *p, char port, int bit, int connected, int level, uint64_t at)
{
	pin_port_t *pp = port_at(p, port);
	if (!pp)
		return;
	uint8_t m = (uint8_t)(1 << bit);
	uint8_t mask = connected ? pp->oc_mask | m : pp->oc_mask & (uint8_t)~m;
	uint8_t levels = level ? pp->oc_level | m : pp->oc_level & (uint8_t)~m;
	if (mask == pp->oc_mask && levels == pp->oc_level)
		return;
	pp->oc_mask = mask;
	pp->oc_level = levels;
	if (!(p->avr->data[pp->io->r_ddr] & m))
		return; /* an input: the compare output does not reach the pin */
	p->change_cycle = at;
	avr_raise_irq(pp->io->io.irq + bit, (uint32_t)output_level(pp, bit));
	p->change_cycle = PINS_NOW;
	log_outputs(pp, at);
}

int pins_level(const pins_t *p, char port, int bit)
{
	const pin_port_t *pp = port_at_const(p, port);
	if (!pp || bit < 0 || bit > 7)
		return -1;
	const uint8_t *d = p->avr->data;
	if (d[pp->io->r_ddr] & (1 << bit))
		return pp->io->io.irq[bit].value & 1; /* as parts on the pin and PCINT see it */
	return (d[pp->io->r_pin] >> bit) & 1;
}

static pin_log_t *log_of(pins_t *p, char port, int bit)
{
	for (int i = 0; i < p->logs; i++)
		if (p->log[i].port == port && p->log[i].bit == bit)
			return &p->log[i];
	return NULL;
}

int pins_log(pins_t *p, char port, int bit, int *level)
{
	pin_port_t *pp = port_at(p, port);
	if (!pp || bit < 0 || bit > 7)
		return PINS_ERR_ARG;
	pin_log_t *l = log_of(p, port, bit);
	if (!l) {
		if (p->logs == PINS_LOGGED)
			return PINS_ERR_NOMEM;
		l = &p->log[p->logs++];
		*l = (pin_log_t){ .port = port, .bit = (uint8_t)bit, .level = (uint8_t)pins_level(p, port, bit) };
		pp->logged |= (uint8_t)(1 << bit);
	}
	*level = l->level;
	return PINS_OK;
}

long pins_take_log(pins_t *p, char port, int bit, pin_edge_t *out, size_t max)
{
	pin_log_t *l = log_of(p, port, bit);
	if (!l)
		return PINS_ERR_ARG;
	size_t n = l->len < max ? l->len : max;
	memcpy(out, l->edges, n * sizeof(*out));
	memmove(l->edges, l->edges + n, (l->len - n) * sizeof(*out));
	l->len -= n;
	return (long)n;
}
