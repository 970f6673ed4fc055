/*
 * simavr 1.6's timers (sim/avr_timer.c), corrected against the ATmega328P datasheet (§16,
 * 16-bit Timer/Counter1; the other timers alike) where a serial line built on a timer
 * (AltSoftSerial's design: the counter free-running in normal mode, input capture on RX,
 * compare unit A setting or clearing TX) would see a difference. Measured with
 * tests/fw/timer_uart.c (tests/timer16.rs) before and after.
 *
 * What simavr gets right, kept: the counter (TCNTn = cycles since the timer started / the
 * prescaler, from the first cycle of the instruction writing TCCRnB; the chip's prescaler
 * runs free, so its phase there is anyone's); the compare match's cycle (when the count
 * moves on from OCRnx, one timer clock after TCNTn == OCRnx, as the datasheet's timing
 * diagrams show), its flag and interrupt; a compare value already passed in this turn of
 * the counter matches only when the counter comes round (65536 ticks later in normal mode).
 *
 * What is replaced here:
 *
 * 1. The compare output (OCnx). simavr raises set/clear on the pin's IRQ beside the port:
 *    (a) it drives the pin even while DDRx makes it an input; (b) the next PORTx or DDRx
 *    write puts PORTx back on the pin, so a program toggling any other pin of the port
 *    glitches the line, and a PINx read returns PORTx; (c) in normal and CTC modes it also
 *    applies the PWM modes' action at BOTTOM: the pin is set at every overflow when COMnx
 *    says "clear", cleared when it says "set", and the same on every OCRnx write (which
 *    re-arms its timers through the overflow code), so writing OCR1A with COM1A = set drives
 *    the line low at once; (d) there is no OCnx latch: connecting COMnx does not show it,
 *    FOCnx does nothing. On the chip OCnx is a latch, reset to 0, that only compare matches
 *    (and FOCnx strobes, in the non-PWM modes) change; while COMnx1:0 is not zero it replaces
 *    PORTx on the pin, visible only where DDRx makes the pin an output. Here each compare
 *    unit with a pin keeps that latch, fed by simavr's compare events (in the non-PWM modes
 *    only those of a match: clear raising 0, set raising 1, any toggle), and hands it to
 *    csrc/pins.c, which shows it on the pin; simavr's own link from the unit to the pin is
 *    cut. The match's exact cycle is computed from the counter, as simavr's cycle timer
 *    runs at the next instruction boundary. A firmware must therefore, as on the chip, set
 *    the latch (COMnx "set" then FOCnx) before it makes the pin an output: the latch is low
 *    after a reset, and connecting COMnx shows it at once.
 * 2. The input capture. simavr stamps ICRn with the count at the instruction boundary after
 *    the pin's change, at once, and ignores the noise canceller. On the chip the pin passes a
 *    synchronizer and edge detector, 2.5-3.5 system clocks ("sampled using the same
 *    technique as for the T1 pin"), and with ICNCn a filter that needs four equal samples
 *    and adds four clocks. Here each change of the pin, at its exact cycle (a scheduled
 *    level's own cycle, see pins.c), reaches the edge detector SYNC_CYCLES (+ NOISE_SAMPLES
 *    with ICNCn) later; a level that did not last one cycle (four with ICNCn) is dropped;
 *    ICESn at that moment picks the edge; ICRn takes the count of that cycle and ICFn rises.
 *    At clk/8 simavr's stamp was one tick early for 3 of the 8 phases of an edge against the
 *    tick without ICNCn, 7 of 8 with it (measured), and a pulse of 1-3 cycles was captured
 *    with ICNCn on.
 * 3. TEMP. simavr stores a 16-bit register's high byte at once and uses it at the low
 *    byte's write, which is right for the datasheet's order (high byte first), but writing
 *    the low byte first then makes OCRnx read back as the value written while the compare
 *    runs on the old high byte, and nothing is shared. On the chip one TEMP register per
 *    16-bit timer takes every high byte written and every high byte read along with a low
 *    byte (TCNTn, ICRn); the low byte's write copies TEMP into the high byte. Modelled here,
 *    so a firmware writing the low byte first, or letting an interrupt touch another 16-bit
 *    register between the two writes, fails as on the chip. (OCRnx reads do not use TEMP.)
 * 4. TIFRn writes. On the chip a flag is cleared by writing a one to its bit, and a zero
 *    leaves it (§16.11.9). simavr 1.6 loses every flag that is up but written zero, and its
 *    interrupt with it: a program clearing ICF1 alone (`TIFR1 = 1 << ICF1`, as a capture
 *    handler does after turning ICES1) dropped a compare match B waiting behind the capture
 *    interrupt. Here a write clears the flags written one, each with its pending interrupt,
 *    and nothing else.
 *
 * Left as simavr has it: FOC0x/FOC2x (the 8-bit timers); two compare units on one pin (the
 * Mega's PB7, OC0A and OC1C, whose modulator is not modelled: the last change shows); the
 * 32U4's OC3B, to which simavr gives OC3A's pin although the chip has no OC3B pin: dropped.
 * A write of TCNTn blocks no compare match (the chip blocks the next timer clock's).
 */
#include <string.h>

#include "sim_cycle_timers.h"
#include "sim_interrupts.h"
#include "sim_io.h"
#include "sim_irq.h"
#include "sim_regbit.h"

#include "timers.h"

/* System clocks from a change on the pin to the edge detector: 2.5-3.5 on the chip. */
#define SYNC_CYCLES 3
/* Samples the noise canceller needs equal (and the clocks it adds) with ICNCn. */
#define NOISE_SAMPLES 4
/* TCCRnB's noise canceller bit (ICESn's register). */
#define ICNC 0x80
/* TCCRnC: FOCnA, FOCnB, FOCnC from bit 7 down. */
#define FOC_A 0x80

static int pwm_mode(const avr_timer_t *p)
{
	return p->wgm_op_mode_kind == avr_timer_wgm_pwm || p->wgm_op_mode_kind == avr_timer_wgm_fast_pwm ||
	       p->wgm_op_mode_kind == avr_timer_wgm_fc_pwm;
}

/* The count in cycle `cycle` (near now), as simavr counts: a tick every prescaler cycles from
 * tov_base, wrapping after TOP. */
static uint16_t count_at(const avr_timer_t *p, uint64_t cycle)
{
	if ((p->ext_clock_flags & (AVR_TIMER_EXTCLK_FLAG_TN | AVR_TIMER_EXTCLK_FLAG_AS2)) &&
	    !(p->ext_clock_flags & AVR_TIMER_EXTCLK_FLAG_VIRT))
		return (uint16_t)p->tov_base; /* clocked from its pin: tov_base is the count */
	uint64_t period = (uint64_t)p->tov_top + 1;
	uint64_t prescale = p->tov_cycles / period;
	if (!prescale)
		return 0; /* stopped: simavr reads 0 */
	int64_t since = (int64_t)(cycle - p->tov_base);
	int64_t ticks = since >= 0 ? since / (int64_t)prescale : -((-since + (int64_t)prescale - 1) / (int64_t)prescale);
	ticks %= (int64_t)period;
	return (uint16_t)(ticks < 0 ? ticks + (int64_t)period : ticks);
}

/* The cycle of the match compare unit `comp` signals now: the last at or before `now` at which
 * the count moved on from OCRnx (tov_base + comp_cycles, a whole number of periods away). */
static uint64_t match_cycle(const avr_timer_t *p, int comp, uint64_t now)
{
	uint64_t period = p->tov_cycles;
	if (!period)
		return now;
	uint64_t at = p->tov_base + p->comp[comp].comp_cycles;
	if (at <= now)
		return now - (now - at) % period;
	return at - (at - now + period - 1) / period * period;
}

static avr_irq_t *pin_irq(const timers_t *t, char port, int bit)
{
	return pins_port(t->pins, port)->io.irq + bit;
}

/* Whether the unit's COMnx bits give it the pin: any but 00; in the PWM modes 01 toggles
 * OCnA if WGMn3 (WGM02 on an 8-bit timer) is set and is a port pin otherwise. */
static int oc_connected(const timer_oc_t *oc)
{
	avr_t *avr = oc->unit->timers->avr;
	const avr_timer_t *p = oc->unit->timer;
	int com = avr_regbit_get(avr, p->comp[oc->comp].com);
	if (com != avr_timer_com_toggle || !pwm_mode(p))
		return com != avr_timer_com_normal;
	avr_regbit_t top_bit = p->wgm[3].reg ? p->wgm[3] : p->wgm[2];
	return oc->comp == AVR_TIMER_COMPA && avr_regbit_get(avr, top_bit);
}

static void oc_show(const timer_oc_t *oc, uint64_t at)
{
	pins_compare_output(oc->unit->timers->pins, oc->port, oc->bit, oc_connected(oc), oc->latch, at);
}

/* simavr's TIMER_IRQ_OUT_COMP: a match's action, or (wrongly, in normal and CTC modes) its
 * PWM action at BOTTOM, which carries the opposite level. */
static void compare_event(avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	timer_oc_t *oc = param;
	avr_t *avr = oc->unit->timers->avr;
	const avr_timer_t *p = oc->unit->timer;
	int com = avr_regbit_get(avr, p->comp[oc->comp].com);
	int level;
	switch (com) {
	case avr_timer_com_toggle:
		level = !oc->latch;
		break;
	case avr_timer_com_clear:
	case avr_timer_com_set:
		level = value & 1;
		if (!pwm_mode(p) && level != (com == avr_timer_com_set))
			return;
		break;
	default:
		return;
	}
	oc->latch = (uint8_t)level;
	oc_show(oc, pwm_mode(p) ? avr->cycle : match_cycle(p, oc->comp, avr->cycle));
}

/* TCCRnA or TCCRnB written: simavr's handler, then COMnx or WGMn may connect or release
 * the pins. */
static void control_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
	timer_unit_t *u = param;
	for (int i = 0; i < 2; i++)
		if (u->control[i].addr == addr) {
			if (u->control[i].c)
				u->control[i].c(avr, addr, v, u->control[i].param);
			else
				avr->data[addr] = v;
		}
	uint64_t at = pins_write_end(avr);
	for (int i = 0; i < u->ocs; i++)
		oc_show(&u->oc[i], at);
}

/* Puts control_write on TCCRnA or TCCRnB (slot `i`), simavr's handler kept. (simavr's own
 * chaining, avr_register_io_write, has room for four shared registers in all.) */
static void control_wrap(timer_unit_t *u, int i, avr_io_addr_t addr)
{
	avr_t *avr = u->timers->avr;
	avr_io_addr_t a = AVR_DATA_TO_IO(addr);
	u->control[i] = (io_write_t){ .addr = addr, .c = avr->io[a].w.c, .param = avr->io[a].w.param };
	avr->io[a].w.c = control_write;
	avr->io[a].w.param = u;
}

/* TCCRnC written: FOCnx applies its unit's match action to OCnx, without flag or interrupt,
 * in the non-PWM modes. The bits are strobes: they read as zero. */
static void force_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
	timer_unit_t *u = param;
	uint64_t at = pins_write_end(avr);
	avr->data[addr] = 0;
	if (pwm_mode(u->timer))
		return;
	for (int i = 0; i < u->ocs; i++) {
		timer_oc_t *oc = &u->oc[i];
		int com = avr_regbit_get(avr, u->timer->comp[oc->comp].com);
		if (!(v & (FOC_A >> oc->comp)) || com == avr_timer_com_normal)
			continue;
		oc->latch = com == avr_timer_com_toggle ? !oc->latch : com == avr_timer_com_set;
		oc_show(oc, at);
	}
}

/* An edge has passed the synchronizer and noise canceller: ICESn picks it or not. */
static void capture(timer_icp_t *c, const capture_edge_t *e)
{
	avr_t *avr = c->unit->timers->avr;
	avr_timer_t *p = c->unit->timer;
	if (p->mode.top == avr_timer_wgm_reg_icr)
		return; /* ICRn holds TOP: the capture unit is off */
	if (e->level != avr_regbit_get(avr, p->ices))
		return;
	uint16_t count = count_at(p, e->due);
	avr->data[p->r_icr] = (uint8_t)count;
	avr->data[p->r_icrh] = (uint8_t)(count >> 8);
	avr_raise_interrupt(avr, &p->icr);
}

static avr_cycle_count_t capture_due(avr_t *avr, avr_cycle_count_t when, void *param)
{
	(void)avr;
	timer_icp_t *c = param;
	while (c->len && c->edge[c->head].due <= when) {
		capture_edge_t e = c->edge[c->head];
		c->head = (c->head + 1) % CAPTURE_EDGES;
		c->len--;
		const capture_edge_t *next = c->len ? &c->edge[c->head] : NULL;
		if (next && next->at - e.at < (e.noise_canceller ? NOISE_SAMPLES : 1))
			continue; /* gone before it was sampled (four times through the noise canceller) */
		if (e.level == c->filtered)
			continue;
		c->filtered = e.level;
		capture(c, &e);
	}
	return c->len ? c->edge[c->head].due : 0;
}

/* The input capture pin changed: at its exact cycle, on its way to the edge detector. */
static void capture_pin(avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	timer_icp_t *c = param;
	timers_t *t = c->unit->timers;
	avr_t *avr = t->avr;
	uint8_t level = value & 1;
	if (level == c->raw)
		return;
	c->raw = level;
	if (c->len == CAPTURE_EDGES)
		return; /* more changes than cycles in the synchronizer: none lasts a sample */
	uint64_t at = pins_change_cycle(t->pins);
	int icnc = (avr->data[c->unit->timer->ices.reg] & ICNC) != 0;
	c->edge[(c->head + c->len) % CAPTURE_EDGES] = (capture_edge_t){
		.at = at,
		.due = at + SYNC_CYCLES + (icnc ? NOISE_SAMPLES : 0),
		.level = level,
		.noise_canceller = (uint8_t)icnc,
	};
	if (c->len++ == 0) {
		uint64_t due = c->edge[c->head].due;
		avr_cycle_timer_register(avr, due > avr->cycle ? due - avr->cycle : 0, capture_due, c);
	}
}

/* A high byte written: to TEMP only. */
static void temp_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
	(void)avr;
	(void)addr;
	((timer_unit_t *)param)->temp = v;
}

/* TCNTn's or ICRn's high byte read: TEMP, which the low byte's read filled. */
static uint8_t temp_read(avr_t *avr, avr_io_addr_t addr, void *param)
{
	(void)avr;
	(void)addr;
	return ((timer_unit_t *)param)->temp;
}

/* A low byte written: TEMP goes to the high byte, then the register is written as simavr
 * writes it. */
static void wide_low_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
	wide_reg_t *w = param;
	avr->data[w->high] = w->unit->temp;
	if (w->write)
		w->write(avr, addr, v, w->write_param);
	else
		avr->data[addr] = v;
}

/* TCNTn's or ICRn's low byte read: the high byte goes to TEMP. */
static uint8_t wide_low_read(avr_t *avr, avr_io_addr_t addr, void *param)
{
	wide_reg_t *w = param;
	uint8_t v = w->read ? w->read(avr, addr, w->read_param) : avr->data[addr];
	w->unit->temp = avr->data[w->high];
	return v;
}

/* Routes the 16-bit register at `low`/`high` through TEMP: its writes, and its reads too if
 * `reads` (TCNTn and ICRn; OCRnx are read directly). simavr's handlers are kept and called. */
static void wide_add(timer_unit_t *u, avr_io_addr_t low, avr_io_addr_t high, int reads)
{
	avr_t *avr = u->timers->avr;
	wide_reg_t *w = &u->wide[u->wides++];
	avr_io_addr_t lo = AVR_DATA_TO_IO(low), hi = AVR_DATA_TO_IO(high);
	*w = (wide_reg_t){ .unit = u, .low = low, .high = high, .write = avr->io[lo].w.c, .write_param = avr->io[lo].w.param };
	avr->io[lo].w.c = wide_low_write;
	avr->io[lo].w.param = w;
	avr->io[hi].w.c = temp_write;
	avr->io[hi].w.param = u;
	if (reads) {
		w->read = avr->io[lo].r.c;
		w->read_param = avr->io[lo].r.param;
		avr->io[lo].r.c = wide_low_read;
		avr->io[lo].r.param = w;
		avr->io[hi].r.c = temp_read;
		avr->io[hi].r.param = u;
	}
}

/* The flags of every timer whose flag register is at `addr`: overflow, capture, compares. */
static int flag_vectors(timers_t *t, avr_io_addr_t addr, avr_int_vector_t **out)
{
	int n = 0;
	for (int i = 0; i < t->units; i++) {
		avr_timer_t *p = t->unit[i].timer;
		avr_int_vector_t *all[2 + AVR_TIMER_COMP_COUNT] = { &p->overflow, &p->icr };
		for (int comp = 0; comp < AVR_TIMER_COMP_COUNT; comp++)
			all[2 + comp] = &p->comp[comp].interrupt;
		for (int k = 0; k < 2 + AVR_TIMER_COMP_COUNT; k++)
			if (all[k]->raised.reg == addr && all[k]->raised.mask)
				out[n++] = all[k];
	}
	return n;
}

/* TIFRn written: each flag written one is cleared with its pending interrupt; the others stay
 * (simavr's handler is not called: it loses them). */
static void flags_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
	avr_int_vector_t *vectors[TIMERS * (2 + AVR_TIMER_COMP_COUNT)];
	int n = flag_vectors(param, addr, vectors);
	for (int i = 0; i < n; i++)
		if (avr_regbit_from_value(avr, vectors[i]->raised, v))
			avr_clear_interrupt(avr, vectors[i]);
}

/* TIMSKn written: an interrupt enabled while its flag is up is taken, as on the chip (its flag
 * requests it whenever the enable bit and I are set). simavr 1.6 queues an interrupt only
 * when its flag rises while it is enabled, and drops it from the queue if it is masked when
 * its turn comes: a flag that rose while masked, or was masked before it was served, brought
 * no interrupt once enabled again (a firmware masking its compare interrupt for a while lost
 * the match that came meanwhile: Timer0's compare B masked while the capture line's slave
 * took a character at 38 400 bps lost a turn of its T3.5, which then ended 1 ms late and
 * took the next frame for part of the last). */
static void mask_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
	avr_timer_t *p = ((timer_unit_t *)param)->timer;
	avr->data[addr] = v;
	avr_int_vector_t *flags[2 + AVR_TIMER_COMP_COUNT] = { &p->overflow, &p->icr };
	for (int comp = 0; comp < AVR_TIMER_COMP_COUNT; comp++)
		flags[2 + comp] = &p->comp[comp].interrupt;
	for (int i = 0; i < 2 + AVR_TIMER_COMP_COUNT; i++) {
		avr_int_vector_t *flag = flags[i];
		if (flag->enable.reg == addr && !flag->pending && avr_regbit_get(avr, flag->enable) &&
		    flag->raised.reg && avr_regbit_get(avr, flag->raised))
			avr_raise_interrupt(avr, flag);
	}
}

static void unit_init(timers_t *t, avr_timer_t *p)
{
	avr_t *avr = t->avr;
	timer_unit_t *u = &t->unit[t->units++];
	u->timers = t;
	u->timer = p;
	for (int comp = 0; comp < AVR_TIMER_COMP_COUNT; comp++) {
		char port;
		int bit, taken = 0;
		if (!p->comp[comp].r_ocr || pins_of_regbit(t->pins, p->comp[comp].com_pin, &port, &bit))
			continue;
		for (int i = 0; i < u->ocs; i++)
			taken |= u->oc[i].port == port && u->oc[i].bit == bit;
		if (taken)
			continue; /* the 32U4's OC3B, on OC3A's pin in simavr: no pin on the chip */
		timer_oc_t *oc = &u->oc[u->ocs++];
		*oc = (timer_oc_t){ .unit = u, .comp = comp, .port = port, .bit = bit };
		avr_irq_register_notify(p->io.irq + TIMER_IRQ_OUT_COMP + comp, compare_event, oc);
	}
	if (u->ocs) {
		control_wrap(u, 0, p->comp[u->oc[0].comp].com.reg);
		control_wrap(u, 1, p->cs[0].reg);
	}
	if (p->r_tcnth) {
		wide_add(u, p->r_tcnt, p->r_tcnth, 1);
		if (p->r_icr)
			wide_add(u, p->r_icr, p->r_icrh, 1);
		for (int comp = 0; comp < AVR_TIMER_COMP_COUNT; comp++)
			if (p->comp[comp].r_ocrh)
				wide_add(u, p->comp[comp].r_ocr, p->comp[comp].r_ocrh, 0);
		if (u->ocs) /* TCCRnC follows TCCRnB on every chip here */
			avr_register_io_write(avr, p->cs[0].reg + 1, force_write, u);
	}
	/* Every timer's interrupt mask, Timer0's too: the crate masks a compare unit of Timer0
	 * while a role's handler runs with interrupts enabled. */
	if (p->overflow.enable.reg)
		avr_register_io_write(avr, p->overflow.enable.reg, mask_write, u);
	char port;
	int bit;
	if (!pins_of_regbit(t->pins, p->icp, &port, &bit)) {
		u->has_icp = 1;
		u->icp.unit = u;
		u->icp.pin = pin_irq(t, port, bit);
		avr_irq_register_notify(u->icp.pin, capture_pin, &u->icp);
	}
}

void timers_init(timers_t *t, avr_t *avr, pins_t *pins)
{
	memset(t, 0, sizeof(*t));
	t->avr = avr;
	t->pins = pins;
	for (avr_io_t *io = avr->io_port; io && t->units < TIMERS; io = io->next)
		if (!strcmp(io->kind, "timer"))
			unit_init(t, (avr_timer_t *)io);
	for (int i = 0; i < t->units; i++) {
		avr_io_addr_t tifr = t->unit[i].timer->overflow.raised.reg;
		if (tifr) {
			avr->io[AVR_DATA_TO_IO(tifr)].w.c = flags_write;
			avr->io[AVR_DATA_TO_IO(tifr)].w.param = t;
		}
	}
	timers_after_reset(t);
}

void timers_after_reset(timers_t *t)
{
	avr_t *avr = t->avr;
	for (int i = 0; i < t->units; i++) {
		timer_unit_t *u = &t->unit[i];
		avr_timer_t *p = u->timer;
		u->temp = 0;
		/* simavr's reset links every compare unit to its pin and the capture pin to the
		 * unit again: cut them */
		for (int comp = 0; comp < AVR_TIMER_COMP_COUNT; comp++) {
			char port;
			int bit;
			if (!pins_of_regbit(t->pins, p->comp[comp].com_pin, &port, &bit))
				avr_unconnect_irq(p->io.irq + TIMER_IRQ_OUT_COMP + comp, pin_irq(t, port, bit));
		}
		for (int k = 0; k < u->ocs; k++)
			u->oc[k].latch = 0;
		if (u->has_icp) {
			timer_icp_t *c = &u->icp;
			avr_unconnect_irq(c->pin, p->io.irq + TIMER_IRQ_IN_ICP);
			avr_cycle_timer_cancel(avr, capture_due, c);
			c->len = 0;
			c->raw = c->filtered = c->pin->value & 1;
		}
	}
}
