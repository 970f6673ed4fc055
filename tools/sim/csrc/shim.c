/*
 * Thin C layer between simavr 1.6 (Debian's libsimavr) and the `uno-sim` crate.
 *
 * simavr simulates the AVR cores (here ATmega328P, 168, 32U4, 1280, 2560) and most
 * peripherals well, but its USART timing is not wire-accurate (see the crate
 * documentation for details). This shim keeps simavr's register handling for one
 * USART, "the wire" (USARTn, whichever the caller picks), and optionally for a second
 * one (a "second wire", e.g. a Mega gateway's other line), and replaces their timing,
 * each wire with its own RX schedule and TX model:
 *
 *   - RX: bytes are written straight into the USART's receive FIFO at the cycle
 *     the caller gives, and RXCn is raised at that very cycle by a simavr cycle
 *     timer. The crate gives the cycle at which the chip's receiver flags the
 *     character: the middle of its first stop bit, half a bit (one and a half with
 *     two stop bits) before the character ends on the line. simavr's own RX pump
 *     (which adds one of *its* character times and lets queued bytes be read early)
 *     is never started.
 *   - TX: every UDRn write is timed against a model of the transmit buffer + shift
 *     register using the character time the firmware configured; UDREn and TXCn are
 *     raised when the real chip would raise them. simavr's TX pump is parked.
 *
 * The chip's other USARTs (those not a wire) run as simavr models them; the bytes they
 * transmit are collected (without timing) so that a test can read, e.g., debug output.
 *
 * Functions that act on one wire take its index: 0 the wire, 1 the second wire.
 *
 * Resets keep the clock running: an external reset (the board's RESET pin, which
 * a USB-serial board pulses when a program opens its port) and a watchdog reset
 * restart the core at its reset address (0, or the bootloader's with BOOTRST) with
 * MCUSR telling why, as the chip does, and drop what was on the wire.
 *
 * The pins (driven from outside at exact cycles, what an output shows, a log of its
 * changes) are csrc/pins.c's; the timers' compare outputs, input captures and 16-bit
 * registers, corrected against the datasheet, csrc/timers.c's.
 *
 * It also adds the AVR's interrupt response time (4 cycles, or 5 with a 3-byte
 * program counter; twice that when waking from sleep), which simavr 1.6 leaves out,
 * and keeps per-vector ISR statistics.
 */
#include <pthread.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sim_avr.h"
#include "sim_cycle_timers.h"
#include "sim_elf.h"
#include "sim_interrupts.h"
#include "sim_io.h"
#include "sim_irq.h"
#include "sim_regbit.h"
#include "avr_adc.h"
#include "avr_eeprom.h"
#include "avr_ioport.h"
#include "avr_uart.h"

#include "avr_extint.h"
#include "pins.h"
#include "spi.h"
#include "timers.h"

DEFINE_FIFO(uint16_t, uart_fifo);

/* Data-space addresses of a wire USART's registers: UCSRnA is at w->base. */
#define R_UCSRA(s) ((s)->base)
#define R_UCSRB(s) ((s)->base + 1)
#define R_UCSRC(s) ((s)->base + 2)
#define R_UBRRL(s) ((s)->base + 4)
#define R_UBRRH(s) ((s)->base + 5)

/* UCSRnA and UCSRnB bits, the same for every USART */
#define FE 4
#define DOR 3
#define UPE 2

#define UCSRB_TXEN 0x08
#define UCSRB_RXCIE 0x80
#define UCSRB_UDRIE 0x20

/* USART0..3 */
#define USARTS 4

/* Marks a received frame with a parity error (bit 15 is simavr's UART_INPUT_FE). */
#define UNO_INPUT_PE 0x4000
#define UNO_INPUT_FLAGS (UART_INPUT_FE | UNO_INPUT_PE)

/* Receive buffer (2 bytes) + receive shift register. */
#define RX_HW_DEPTH 3

#define ISR_VECTORS 64

enum { UNO_OK = 0, UNO_ERR_PAST = -1, UNO_ERR_ORDER = -2, UNO_ERR_NOMEM = -3, UNO_ERR_ARG = -4 };

typedef struct {
	uint64_t at;
	uint16_t value;
} rx_item_t;

/* Must match `TxRaw` in src/ffi.rs. */
typedef struct {
	uint64_t start;
	uint64_t end;
	uint8_t byte;
} uno_tx_t;

/* Must match `IsrRaw` in src/ffi.rs. */
typedef struct {
	uint64_t entries;
	uint64_t cycles;
	uint64_t max_cycles;
} uno_isr_t;

/* Bytes another USART transmitted (simavr's UART_IRQ_OUTPUT). */
typedef struct {
	uint8_t *bytes;
	size_t len, cap;
} usart_out_t;

/* Wires: USART0..3 timed as described above (the first is the one `uno_new` names). */
#define WIRES 2

/* One timed USART. */
typedef struct uno_wire {
	struct uno_shim *shim;
	avr_uart_t *uart;            /* NULL: not in use */
	uint16_t base;               /* its UCSRnA */
	char uart_name;              /* '0'..'3' */
	avr_cycle_timer_t uart_pump; /* simavr's static TX pump, found on first UDRn write */

	/* RX schedule, sorted by `at` */
	rx_item_t *rx;
	size_t rx_head, rx_len, rx_cap;
	uint64_t rx_dropped, rx_overruns;

	/* TX model */
	int tx_active;         /* a frame is in the shift register */
	uint64_t tx_shift_end; /* its stop bit ends here */
	int tx_buf_full;       /* a second frame waits in UDRn */
	uint64_t tx_buf_end;   /* when that one will end */
	int tx_written;        /* UDRn was written during the current instruction */
	uint64_t tx_ignored;   /* writes while UDREn was clear (ignored by the chip) */
	uno_tx_t *tx;
	size_t tx_len, tx_cap;

	/* DORn and the receive FIFO's read cursor before the current instruction */
	int dor_before;
	unsigned read_before;
} wire_t;

typedef struct uno_shim {
	avr_t *avr;
	wire_t wire[WIRES];          /* wire[0]: the wire; wire[1]: a second one, if asked for */
	usart_out_t out[USARTS];     /* what the other USARTs sent */

	/* interrupt bookkeeping */
	uint64_t response;     /* interrupt response cycles (4, or 5 with a 3-byte PC) */
	int was_sleeping;
	uint64_t entry_added;
	int entered_vec;
	uno_isr_t isr[ISR_VECTORS];
	uint64_t isr_start[ISR_VECTORS];
	int isr_depth;
	int reti_pending;
	uint8_t reti_vec;
	uint64_t reti_start;

	/* resets after the first start: how many, and MCUSR's cause bits of the last one */
	void (*core_run)(avr_t *avr); /* simavr's run function; the watchdog swaps it to reset */
	uint64_t resets;
	uint8_t reset_cause;

	/* the pins: driven from outside (now or at a scheduled cycle), shown, logged */
	pins_t pins;
	/* the timers' compare outputs, input captures and TEMP, as the chip has them */
	timers_t timers;

	/* a part on the SPI bus (spi.c), if one is attached */
	spi_part_t spi_part;
	/* The pin the SPI part's INT line drives (uno_spi_int). */
	char spi_int_port;
	int spi_int_bit;
} uno_shim_t;

/* ------------------------------------------------------------------------- */
/* logging                                                                   */

static __thread char last_error[256];

static void quiet_logger(avr_t *avr, const int level, const char *format, va_list ap)
{
	if (level > LOG_ERROR || level == LOG_NONE)
		return;
	char line[sizeof(last_error)];
	vsnprintf(line, sizeof(line), format, ap);
	size_t n = strlen(line);
	while (n && (line[n - 1] == '\n' || line[n - 1] == '\r'))
		line[--n] = 0;
	if (level == LOG_ERROR) {
		memcpy(last_error, line, n + 1);
		/* errors at load time are returned to the caller instead */
		if (avr)
			fprintf(stderr, "simavr: %s\n", line);
	}
}

static pthread_once_t logger_once = PTHREAD_ONCE_INIT;

static void install_logger(void)
{
	avr_global_logger_set(quiet_logger);
}

/* ------------------------------------------------------------------------- */
/* helpers                                                                   */

static uint64_t char_cycles(const wire_t *w)
{
	const uint8_t *d = w->shim->avr->data;
	uint8_t a = d[R_UCSRA(w)], b = d[R_UCSRB(w)], c = d[R_UCSRC(w)];
	uint64_t ubrr = ((uint64_t)(d[R_UBRRH(w)] & 0x0F) << 8) | d[R_UBRRL(w)];
	uint64_t bit = (ubrr + 1) * ((a & 0x02) ? 8 : 16);
	int ucsz = ((c >> 1) & 3) | ((b & 0x04) ? 4 : 0);
	int data_bits = ucsz <= 3 ? 5 + ucsz : (ucsz == 7 ? 9 : 8);
	int parity = ((c >> 4) & 3) >= 2 ? 1 : 0;
	int stop = (c & 0x08) ? 2 : 1;
	return bit * (uint64_t)(1 + data_bits + parity + stop);
}

static void clear_flag(avr_t *avr, avr_int_vector_t *v)
{
	if (avr_regbit_get(avr, v->raised) || v->pending) {
		avr_clear_interrupt(avr, v);
		avr_regbit_clear(avr, v->raised);
	}
}

/* Park simavr's TX pump: keep it "flying" (far in the future) while UDRn holds a
 * byte, so that enabling UDRIEn does not raise UDREn; remove it otherwise. */
static void park_uart_pump(wire_t *w)
{
	avr_t *avr = w->shim->avr;
	avr_uart_t *p = w->uart;
	if (!w->uart_pump) {
		for (avr_cycle_timer_slot_p t = avr->cycle_timers.timer; t; t = t->next)
			if (t->param == p) {
				w->uart_pump = t->timer;
				break;
			}
	}
	if (w->uart_pump) {
		if (w->tx_buf_full)
			avr_cycle_timer_register(avr, (avr_cycle_count_t)1 << 60, w->uart_pump, p);
		else
			avr_cycle_timer_cancel(avr, w->uart_pump, p);
	}
	p->tx_cnt = 0;
}

/* ------------------------------------------------------------------------- */
/* TX                                                                        */

static void tx_push_log(wire_t *w, uint8_t byte, uint64_t start, uint64_t end)
{
	if (w->tx_len == w->tx_cap) {
		size_t cap = w->tx_cap ? w->tx_cap * 2 : 256;
		uno_tx_t *n = realloc(w->tx, cap * sizeof(*n));
		if (!n)
			return;
		w->tx = n;
		w->tx_cap = cap;
	}
	w->tx[w->tx_len++] = (uno_tx_t){ .start = start, .end = end, .byte = byte };
}

/* Advance the transmitter model to cycle `now`. */
static void tx_catch_up(wire_t *w, uint64_t now)
{
	avr_t *avr = w->shim->avr;
	while (w->tx_active && w->tx_shift_end <= now) {
		if (w->tx_buf_full) {
			/* UDRn -> shift register right after the previous stop bit */
			w->tx_shift_end = w->tx_buf_end;
			w->tx_buf_full = 0;
			avr_raise_interrupt(avr, &w->uart->udrc);
			park_uart_pump(w);
		} else {
			w->tx_active = 0;
			avr_raise_interrupt(avr, &w->uart->txc);
		}
	}
}

static avr_cycle_count_t tx_timer(avr_t *avr, avr_cycle_count_t when, void *param)
{
	(void)avr;
	wire_t *w = param;
	tx_catch_up(w, when);
	return w->tx_active ? w->tx_shift_end : 0;
}

/* UART_IRQ_OUTPUT: raised by simavr from within the UDRn write (only when TXENn is
 * set), after it has cleared UDREn. avr->cycle is the first cycle of the ST/STS. */
static void tx_output_irq(avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	wire_t *w = param;
	avr_t *avr = w->shim->avr;
	uint64_t written = avr->cycle + 2; /* ST/STS take 2 cycles; the write lands at the end */
	uint64_t ch = char_cycles(w);

	w->tx_written = 1;
	tx_catch_up(w, written);
	if (!w->tx_active) {
		w->tx_active = 1;
		w->tx_shift_end = written + ch;
		tx_push_log(w, (uint8_t)value, written, w->tx_shift_end);
		avr_cycle_timer_register(avr, w->tx_shift_end - avr->cycle, tx_timer, w);
		/* straight into the shift register: the buffer is empty again */
		avr_raise_interrupt(avr, &w->uart->udrc);
	} else if (!w->tx_buf_full) {
		w->tx_buf_full = 1;
		w->tx_buf_end = w->tx_shift_end + ch;
		tx_push_log(w, (uint8_t)value, w->tx_shift_end, w->tx_buf_end);
	} else {
		/* data sheet: written while UDREn is clear -> ignored by the transmitter */
		w->tx_ignored++;
	}
}

/* UART_IRQ_OUTPUT of another USART: keep the byte for uno_usart_take(). */
static void other_output_irq(avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	usart_out_t *o = param;
	if (o->len == o->cap) {
		size_t cap = o->cap ? o->cap * 2 : 256;
		uint8_t *n = realloc(o->bytes, cap);
		if (!n)
			return;
		o->bytes = n;
		o->cap = cap;
	}
	o->bytes[o->len++] = (uint8_t)value;
}

/* ------------------------------------------------------------------------- */
/* RX                                                                        */

static void rx_deliver(wire_t *w, uint16_t value)
{
	avr_t *avr = w->shim->avr;
	avr_uart_t *p = w->uart;
	if (!avr_regbit_get(avr, p->rxen)) {
		w->rx_dropped++;
		return;
	}
	uart_fifo_t *f = &p->input;
	unsigned count = (unsigned)(f->write - f->read) & (uart_fifo_fifo_size - 1);
	if (count >= RX_HW_DEPTH) {
		/* data overrun: the new frame replaces the one waiting in the shift register */
		f->buffer[(f->write - 1) & (uart_fifo_fifo_size - 1)] = value;
		avr_regbit_set(avr, p->dor);
		w->rx_overruns++;
	} else {
		uart_fifo_write(f, value);
	}
	avr_raise_interrupt(avr, &p->rxc);
}

static avr_cycle_count_t rx_timer(avr_t *avr, avr_cycle_count_t when, void *param)
{
	(void)avr;
	wire_t *w = param;
	while (w->rx_head < w->rx_len && w->rx[w->rx_head].at <= when) {
		rx_deliver(w, w->rx[w->rx_head].value);
		w->rx_head++;
	}
	if (w->rx_head == w->rx_len) {
		w->rx_head = w->rx_len = 0;
		return 0;
	}
	return w->rx[w->rx_head].at;
}

/* ------------------------------------------------------------------------- */
/* interrupts                                                                */

static void finish_reti(uno_shim_t *s)
{
	if (!s->reti_pending)
		return;
	s->reti_pending = 0;
	uint64_t d = s->avr->cycle - s->reti_start;
	if (d > s->isr[s->reti_vec].max_cycles)
		s->isr[s->reti_vec].max_cycles = d;
}

/* Per-vector AVR_INT_IRQ_RUNNING: 1 when the vector is entered, 0 on its RETI. */
static void isr_running_irq(avr_irq_t *irq, uint32_t value, void *param)
{
	uno_shim_t *s = param;
	avr_t *avr = s->avr;
	avr_int_vector_t *v =
		(avr_int_vector_t *)((char *)irq - offsetof(avr_int_vector_t, irq[AVR_INT_IRQ_RUNNING]));
	uint8_t vec = v->vector & (ISR_VECTORS - 1);
	if (value) {
		finish_reti(s);
		/* interrupt response: 4 or 5 cycles (PC push), as many again when waking up */
		uint64_t extra = s->was_sleeping ? 2 * s->response : s->response;
		if (s->isr_depth < ISR_VECTORS)
			s->isr_start[s->isr_depth] = avr->cycle;
		s->isr_depth++;
		avr->cycle += extra;
		s->entry_added += extra;
		s->isr[vec].entries++;
		s->entered_vec = vec;
		s->isr[vec].cycles += extra;
	} else if (s->isr_depth > 0) {
		s->isr_depth--;
		s->reti_pending = 1;
		s->reti_vec = vec;
		s->reti_start = s->isr_depth < ISR_VECTORS ? s->isr_start[s->isr_depth] : avr->cycle;
	}
}

/* ------------------------------------------------------------------------- */
/* stepping                                                                  */

static void sleep_exact(avr_t *avr, avr_cycle_count_t how_long)
{
	/* simavr advances a sleeping core by 1 + how_long, i.e. one cycle past the next
	 * timer; compensate so it lands exactly on it. No host-side sleeping. */
	(void)how_long;
	avr->cycle -= 1;
}

static avr_cycle_count_t stop_timer(avr_t *avr, avr_cycle_count_t when, void *param)
{
	(void)avr;
	(void)when;
	(void)param;
	return 0;
}

/* Before every instruction: what post_step compares with. */
static void pre_step(wire_t *w)
{
	w->dor_before = (w->shim->avr->data[R_UCSRA(w)] >> DOR) & 1;
	w->read_before = w->uart->input.read;
}

/* After every instruction: restore the hardware invariants simavr would break on wire
 * `w`, against DORn and the receive FIFO's read cursor before it (pre_step). */
static void post_step(wire_t *w)
{
	avr_t *avr = w->shim->avr;
	avr_uart_t *p = w->uart;
	uint8_t ucsrb = avr->data[R_UCSRB(w)];

	/* DORn is read-only on the chip; simavr clears it on any UCSRnA write. Only reading
	 * UDRn may clear it. */
	if (w->dor_before && p->input.read == w->read_before)
		avr->data[R_UCSRA(w)] |= 1 << DOR;

	/* disarm simavr's "bytes read too fast" check: our FIFO only holds received bytes */
	p->rx_cnt = 0;
	if (w->tx_written) {
		w->tx_written = 0;
		park_uart_pump(w);
	}

	/* UDREn == transmit buffer empty; level-triggered interrupt */
	int udre = avr_regbit_get(avr, p->udrc.raised);
	if (w->tx_buf_full) {
		if (udre)
			clear_flag(avr, &p->udrc);
	} else if (!udre || ((ucsrb & UCSRB_UDRIE) && !p->udrc.pending)) {
		avr_raise_interrupt(avr, &p->udrc);
	}

	/* RXCn == receive buffer not empty; level-triggered interrupt */
	uart_fifo_t *f = &p->input;
	int have = f->read != f->write;
	if (have) {
		if (!avr_regbit_get(avr, p->rxc.raised) || ((ucsrb & UCSRB_RXCIE) && !p->rxc.pending))
			avr_raise_interrupt(avr, &p->rxc);
		/* FEn (simavr sets it on UCSRnA reads) and UPEn follow the oldest unread frame */
		uint16_t head = f->buffer[f->read & (uart_fifo_fifo_size - 1)];
		uint8_t a = avr->data[R_UCSRA(w)] & (uint8_t)~((1 << FE) | (1 << UPE));
		if (head & UART_INPUT_FE)
			a |= 1 << FE;
		if (head & UNO_INPUT_PE)
			a |= 1 << UPE;
		avr->data[R_UCSRA(w)] = a;
	} else {
		avr->data[R_UCSRA(w)] &= (uint8_t)~((1 << FE) | (1 << UPE));
	}
}

/* MCUSR, the same data address on every chip simulated here */
#define R_MCUSR 0x54

/* MCUSR's flags are set by the resets alone: a write clears the flags written as zero
 * and sets none (simavr keeps whatever is written). A program overrunning its stack into
 * the I/O registers (a bootloader jumping to erased flash, over and over) must not fake
 * a reset cause. */
static void mcusr_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
	(void)param;
	avr->data[addr] &= v;
}

/* EEARH has as many bits as the EEPROM needs (two on the 328P); the others read as zero.
 * simavr keeps the whole byte and logs every read beyond the EEPROM. */
static void eearh_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
	(void)param;
	avr->data[addr] = v & (uint8_t)(avr->e2end >> 8);
}

/* A stack pointer decremented past 0 (a program pushing without end: a bootloader jumping
 * to erased flash again and again, its return address left on the stack each time) wraps
 * on the chip into addresses with no memory, whose writes are lost, and comes down into
 * SRAM again. simavr stops the core at the first such write. Here it wraps to RAMEND at
 * once: the same writes, sooner. (Every RAMEND here ends in 0xFF, so no program setting SP
 * high byte first passes through a value above it.) A push of two or three bytes from SP 0
 * still stops the core. */
static void sph_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
	(void)param;
	avr->data[addr] = v;
	uint32_t sp = avr->data[R_SPL] | (uint32_t)v << 8;
	if (sp > avr->ramend) {
		sp = (sp + avr->ramend + 1) & 0xFFFF;
		while (sp > avr->ramend)
			sp -= avr->ramend + 1;
		avr->data[R_SPL] = (uint8_t)sp;
		avr->data[R_SPH] = (uint8_t)(sp >> 8);
	}
}

/* simavr enables every transmitter at reset "to allow printf"; the chip does not. */
static void uarts_off(avr_t *avr)
{
	for (avr_io_t *io = avr->io_port; io; io = io->next)
		if (!strcmp(io->kind, "uart"))
			avr_regbit_clear(avr, ((avr_uart_t *)io)->txen);
}

/* A reset of the core that keeps the clock, the flash, the EEPROM and SRAM (the chip
 * clears only its I/O registers), with `cause` ORed into MCUSR. Characters on the wire
 * in either direction are lost; the statistics stay. */
static void chip_reset(uno_shim_t *s, uint8_t cause)
{
	avr_t *avr = s->avr;
	uint64_t cycle = avr->cycle;
	avr_reset(avr); /* drops every cycle timer: the RX schedule and the TX model go too */
	avr->cycle = cycle;
	uarts_off(avr);
	pins_after_reset(&s->pins);
	timers_after_reset(&s->timers);
	avr->data[R_MCUSR] |= cause;
	s->reset_cause = avr->data[R_MCUSR];
	s->resets++;
	for (int i = 0; i < WIRES; i++) {
		wire_t *w = &s->wire[i];
		w->rx_head = w->rx_len = 0;
		w->tx_active = w->tx_buf_full = w->tx_written = 0;
	}
	s->isr_depth = 0;
	s->reti_pending = 0;
	s->was_sleeping = 0;
}

static void step_once(uno_shim_t *s)
{
	avr_t *avr = s->avr;
	uint8_t depth = avr->interrupts.running_ptr;
	uint8_t vec = depth ? avr->interrupts.running[depth - 1]->vector & (ISR_VECTORS - 1) : 0;
	uint64_t c0 = avr->cycle;

	for (int i = 0; i < WIRES; i++)
		if (s->wire[i].uart)
			pre_step(&s->wire[i]);

	s->was_sleeping = avr->state == cpu_Sleeping;
	s->entry_added = 0;
	s->entered_vec = -1;
	avr_run(avr);
	if (depth)
		s->isr[vec].cycles += avr->cycle - c0 - s->entry_added;
	finish_reti(s);
	for (int i = 0; i < WIRES; i++)
		if (s->wire[i].uart)
			post_step(&s->wire[i]);
	/* simavr's watchdog fired with WDE set: it swapped avr->run for its reset, which
	 * would drop this shim's timers; reset here instead (its I/O reset sets WDRF). */
	if (avr->run != s->core_run)
		chip_reset(s, 0);
}

/* ------------------------------------------------------------------------- */
/* public API                                                                */

void uno_free(uno_shim_t *s);

/* Loads the ELF file at `path` (NULL: none, the flash erased) into a fresh `mcu`
 * (simavr's core name) at 16 MHz and makes USART`usart` the wire (wire 0); its UCSRnA must be
 * at `base` (the caller's table, checked against simavr's core). `usart2` (-1: none) is a
 * second timed wire (wire 1), with its UCSRnA at `base2`. `response`: interrupt response
 * cycles. */
uno_shim_t *uno_new(const char *path, const char *mcu, int usart, uint16_t base, int usart2, uint16_t base2,
		    uint32_t response, char *err, size_t errlen)
{
	pthread_once(&logger_once, install_logger);
	last_error[0] = 0;
	if (errlen)
		err[0] = 0;
	if (usart < 0 || usart >= USARTS) {
		snprintf(err, errlen, "USART%d does not exist", usart);
		return NULL;
	}
	if (usart2 >= USARTS || usart2 == usart) {
		snprintf(err, errlen, usart2 == usart ? "USART%d is already the wire" : "USART%d does not exist",
			 usart2);
		return NULL;
	}
	int wires = usart2 >= 0 ? 2 : 1;
	const int usart_of[WIRES] = { usart, usart2 };
	const uint16_t base_of[WIRES] = { base, base2 };

	elf_firmware_t *f = calloc(1, sizeof(*f) + 4096);
	uno_shim_t *s = calloc(1, sizeof(*s));
	if (!f || !s) {
		snprintf(err, errlen, "out of memory");
		free(f);
		free(s);
		return NULL;
	}
	if (path && elf_read_firmware(path, f) != 0) {
		snprintf(err, errlen, "simavr could not read the ELF file%s%s", last_error[0] ? ": " : "",
			 last_error);
		goto fail;
	}
	s->avr = avr_make_mcu_by_name(mcu);
	if (!s->avr) {
		snprintf(err, errlen, "simavr has no %s core", mcu);
		goto fail;
	}
	avr_init(s->avr);
	if (path && (!f->flash || f->flashsize == 0)) {
		snprintf(err, errlen, "the ELF file has no code for flash");
		goto fail;
	}
	if ((uint64_t)f->flashbase + f->flashsize > (uint64_t)s->avr->flashend + 1) {
		snprintf(err, errlen, "the code (%u bytes at 0x%x) does not fit the %s's %u KiB flash",
			 (unsigned)f->flashsize, (unsigned)f->flashbase, mcu, (unsigned)((s->avr->flashend + 1) / 1024));
		goto fail;
	}
	if (f->eeprom && f->eesize > (uint64_t)s->avr->e2end + 1) {
		snprintf(err, errlen, "the .eeprom section (%u bytes) does not fit the %s's %u-byte EEPROM",
			 (unsigned)f->eesize, mcu, (unsigned)(s->avr->e2end + 1));
		goto fail;
	}
	f->frequency = 16000000;
	if (path)
		avr_load_firmware(s->avr, f);

	avr_t *avr = s->avr;
	avr->frequency = 16000000;
	avr->vcc = avr->avcc = avr->aref = 5000;
	avr->log = LOG_ERROR;
	avr->sleep = sleep_exact;
	s->core_run = avr->run;
	s->response = response;
	pins_init(&s->pins, avr);
	timers_init(&s->timers, avr, &s->pins);
	for (int i = 0; i < wires; i++) {
		s->wire[i].shim = s;
		s->wire[i].uart_name = (char)('0' + usart_of[i]);
		s->wire[i].base = base_of[i];
	}

	for (avr_io_t *io = avr->io_port; io; io = io->next) {
		if (strcmp(io->kind, "uart"))
			continue;
		avr_uart_t *u = (avr_uart_t *)io;
		uint32_t flags = 0;
		avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS(u->name), &flags);
		flags &= ~(uint32_t)(AVR_UART_FLAG_POLL_SLEEP | AVR_UART_FLAG_STDIO);
		avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS(u->name), &flags);
		avr_irq_t *output = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ(u->name), UART_IRQ_OUTPUT);
		wire_t *w = NULL;
		for (int i = 0; i < wires; i++)
			if (u->name == s->wire[i].uart_name)
				w = &s->wire[i];
		if (w) {
			w->uart = u;
			avr_irq_register_notify(output, tx_output_irq, w);
		} else if (u->name >= '0' && u->name < '0' + USARTS) {
			avr_irq_register_notify(output, other_output_irq, &s->out[u->name - '0']);
		}
	}
	uarts_off(avr);
	for (int i = 0; i < wires; i++) {
		wire_t *w = &s->wire[i];
		if (!w->uart) {
			snprintf(err, errlen, "simavr's %s core has no USART%d", mcu, usart_of[i]);
			goto fail;
		}
		if (w->uart->r_ucsra != base_of[i]) {
			snprintf(err, errlen, "simavr's %s core has UCSR%dA at 0x%x, not 0x%x", mcu, usart_of[i],
				 (unsigned)w->uart->r_ucsra, (unsigned)base_of[i]);
			goto fail;
		}
	}

	for (int i = 0; i < avr->interrupts.vector_count; i++)
		avr_irq_register_notify(&avr->interrupts.vector[i]->irq[AVR_INT_IRQ_RUNNING], isr_running_irq, s);
	avr_register_io_write(avr, R_MCUSR, mcusr_write, NULL);
	spi_fix_timing(avr); /* -1: a core without SPI, nothing to fix */
	avr_register_io_write(avr, R_SPH, sph_write, NULL);
	for (avr_io_t *io = avr->io_port; io; io = io->next)
		if (!strcmp(io->kind, "eeprom") && ((avr_eeprom_t *)io)->r_eearh)
			avr_register_io_write(avr, ((avr_eeprom_t *)io)->r_eearh, eearh_write, NULL);

	free(f->flash);
	free(f->eeprom);
	free(f);
	return s;
fail:
	free(f->flash);
	free(f->eeprom);
	free(f);
	uno_free(s);
	return NULL;
}

void uno_free(uno_shim_t *s)
{
	if (!s)
		return;
	if (s->avr) {
		avr_terminate(s->avr);
		free(s->avr);
	}
	for (int i = 0; i < WIRES; i++) {
		free(s->wire[i].rx);
		free(s->wire[i].tx);
	}
	for (int i = 0; i < USARTS; i++)
		free(s->out[i].bytes);
	pins_free(&s->pins);
	free(s);
}

uint64_t uno_cycle(const uno_shim_t *s)
{
	return s->avr->cycle;
}

int uno_state(const uno_shim_t *s)
{
	return s->avr->state;
}

static int runnable(const uno_shim_t *s)
{
	return s->avr->state == cpu_Running || s->avr->state == cpu_Sleeping;
}

static int tx_logged(const uno_shim_t *s, int wires, size_t *len)
{
	int changed = 0;
	for (int i = 0; i < WIRES; i++)
		if (wires & (1 << i)) {
			changed |= s->wire[i].tx_len != len[i];
			len[i] = s->wire[i].tx_len;
		}
	return changed;
}

/* Run until the clock reaches `target`, the core stops, or the firmware writes UDRn
 * of a wire in `stop_on_tx` (bit 0: wire 0, bit 1: wire 1). Returns the core state. */
int uno_run(uno_shim_t *s, uint64_t target, int stop_on_tx)
{
	avr_t *avr = s->avr;
	if (avr->cycle < target)
		avr_cycle_timer_register(avr, target - avr->cycle, stop_timer, s);
	size_t tx0[WIRES] = {0};
	tx_logged(s, stop_on_tx, tx0);
	while (avr->cycle < target && runnable(s)) {
		step_once(s);
		if (stop_on_tx && tx_logged(s, stop_on_tx, tx0))
			break;
	}
	avr_cycle_timer_cancel(avr, stop_timer, s);
	return avr->state;
}

/* One instruction (or, while sleeping, a jump to the next event but not past
 * `limit`). Stores the PC of the instruction, the vector it ran in (-1: none), the
 * vector entered after it (-1: none) and the interrupt response cycles added. */
int uno_step(uno_shim_t *s, uint64_t limit, uint32_t *pc, int *vector, int *entered, uint64_t *response)
{
	avr_t *avr = s->avr;
	uint8_t depth = avr->interrupts.running_ptr;
	*pc = avr->pc;
	*vector = depth ? avr->interrupts.running[depth - 1]->vector : -1;
	*entered = -1;
	*response = 0;
	if (!runnable(s))
		return avr->state;
	if (avr->cycle < limit)
		avr_cycle_timer_register(avr, limit - avr->cycle, stop_timer, s);
	step_once(s);
	avr_cycle_timer_cancel(avr, stop_timer, s);
	*entered = s->entered_vec;
	*response = s->entry_added;
	return avr->state;
}

uint32_t uno_pc(const uno_shim_t *s)
{
	return s->avr->pc;
}

uint8_t uno_sreg(const uno_shim_t *s)
{
	uint8_t v = 0;
	for (int i = 0; i < 8; i++)
		if (s->avr->sreg[i])
			v |= (uint8_t)(1 << i);
	return v;
}

int uno_running_vector(const uno_shim_t *s)
{
	uint8_t depth = s->avr->interrupts.running_ptr;
	return depth ? s->avr->interrupts.running[depth - 1]->vector : -1;
}

void uno_isr_stats(const uno_shim_t *s, uint8_t vector, uno_isr_t *out)
{
	*out = s->isr[vector & (ISR_VECTORS - 1)];
}

void uno_isr_reset(uno_shim_t *s)
{
	memset(s->isr, 0, sizeof(s->isr));
}

/* Wire `i`, or NULL if there is no such wire. */
static wire_t *wire_at(uno_shim_t *s, int i)
{
	return i >= 0 && i < WIRES && s->wire[i].uart ? &s->wire[i] : NULL;
}

static const wire_t *wire_at_const(const uno_shim_t *s, int i)
{
	return i >= 0 && i < WIRES && s->wire[i].uart ? &s->wire[i] : NULL;
}

/* Schedule a received frame on wire `wire`: `value` is the data byte, optionally ORed with
 * UART_INPUT_FE (0x8000) / UNO_INPUT_PE (0x4000); it enters the receive buffer and
 * RXCn rises at cycle `at` (the crate passes the middle of the first stop bit). */
int uno_rx_push(uno_shim_t *s, int wire, uint64_t at, uint16_t value)
{
	avr_t *avr = s->avr;
	wire_t *w = wire_at(s, wire);
	if (!w)
		return UNO_ERR_ARG;
	if (at < avr->cycle)
		return UNO_ERR_PAST;
	if (value & ~(0xFF | UNO_INPUT_FLAGS))
		return UNO_ERR_ARG;
	if (w->rx_len > w->rx_head && at < w->rx[w->rx_len - 1].at)
		return UNO_ERR_ORDER;
	if (w->rx_len == w->rx_cap) {
		if (w->rx_head > 0) {
			memmove(w->rx, w->rx + w->rx_head, (w->rx_len - w->rx_head) * sizeof(*w->rx));
			w->rx_len -= w->rx_head;
			w->rx_head = 0;
		} else {
			size_t cap = w->rx_cap ? w->rx_cap * 2 : 256;
			rx_item_t *n = realloc(w->rx, cap * sizeof(*n));
			if (!n)
				return UNO_ERR_NOMEM;
			w->rx = n;
			w->rx_cap = cap;
		}
	}
	int was_empty = w->rx_head == w->rx_len;
	w->rx[w->rx_len++] = (rx_item_t){ .at = at, .value = value };
	if (was_empty)
		avr_cycle_timer_register(avr, at - avr->cycle, rx_timer, w);
	return UNO_OK;
}

size_t uno_rx_pending(const uno_shim_t *s, int wire)
{
	const wire_t *w = wire_at_const(s, wire);
	return w ? w->rx_len - w->rx_head : 0;
}

void uno_rx_clear(uno_shim_t *s, int wire)
{
	wire_t *w = wire_at(s, wire);
	if (!w)
		return;
	w->rx_head = w->rx_len = 0;
	avr_cycle_timer_cancel(s->avr, rx_timer, w);
}

void uno_uart_counters(const uno_shim_t *s, int wire, uint64_t *rx_dropped, uint64_t *rx_overruns,
		       uint64_t *tx_ignored)
{
	const wire_t *w = wire_at_const(s, wire);
	*rx_dropped = w ? w->rx_dropped : 0;
	*rx_overruns = w ? w->rx_overruns : 0;
	*tx_ignored = w ? w->tx_ignored : 0;
}

size_t uno_tx_len(const uno_shim_t *s, int wire)
{
	const wire_t *w = wire_at_const(s, wire);
	return w ? w->tx_len : 0;
}

/* Move up to `max` frames logged on wire `wire` (oldest first) to `out`. */
size_t uno_tx_take(uno_shim_t *s, int wire, uno_tx_t *out, size_t max)
{
	wire_t *w = wire_at(s, wire);
	if (!w)
		return 0;
	size_t n = w->tx_len < max ? w->tx_len : max;
	memcpy(out, w->tx, n * sizeof(*out));
	memmove(w->tx, w->tx + n, (w->tx_len - n) * sizeof(*out));
	w->tx_len -= n;
	return n;
}

/* Cycle at which wire `wire`'s transmitter becomes idle (0 if it already is). */
uint64_t uno_tx_busy_until(const uno_shim_t *s, int wire)
{
	const wire_t *w = wire_at_const(s, wire);
	if (!w || !w->tx_active)
		return 0;
	return w->tx_buf_full ? w->tx_buf_end : w->tx_shift_end;
}

uint32_t uno_uart_flags(const uno_shim_t *s)
{
	uint32_t flags = 0;
	avr_ioctl(s->avr, AVR_IOCTL_UART_GET_FLAGS(s->wire[0].uart_name), &flags);
	return flags;
}

uint8_t *uno_data(uno_shim_t *s, size_t *len)
{
	*len = (size_t)s->avr->ramend + 1;
	return s->avr->data;
}

/* Move up to `max` bytes USART`usart` (not a wire) transmitted, oldest first, to
 * `out`. Returns how many, or UNO_ERR_ARG for a wire or a USART out of range. */
long uno_usart_take(uno_shim_t *s, int usart, uint8_t *out, size_t max)
{
	if (usart < 0 || usart >= USARTS)
		return UNO_ERR_ARG;
	for (int i = 0; i < WIRES; i++)
		if (s->wire[i].uart && '0' + usart == s->wire[i].uart_name)
			return UNO_ERR_ARG;
	usart_out_t *o = &s->out[usart];
	size_t n = o->len < max ? o->len : max;
	memcpy(out, o->bytes, n);
	memmove(o->bytes, o->bytes + n, o->len - n);
	o->len -= n;
	return (long)n;
}

/* Data-space addresses of PINx, DDRx and PORTx of port `port`; UNO_ERR_ARG if the chip
 * has no such port. */
int uno_port_regs(const uno_shim_t *s, char port, uint16_t *pin, uint16_t *ddr, uint16_t *portreg)
{
	avr_ioport_t *p = pins_port(&s->pins, port);
	if (!p)
		return UNO_ERR_ARG;
	*pin = p->r_pin;
	*ddr = p->r_ddr;
	*portreg = p->r_port;
	return UNO_OK;
}

static int pins_error(int err)
{
	switch (err) {
	case PINS_OK:
		return UNO_OK;
	case PINS_ERR_PAST:
		return UNO_ERR_PAST;
	case PINS_ERR_NOMEM:
		return UNO_ERR_NOMEM;
	default:
		return UNO_ERR_ARG;
	}
}

/* Drive input `bit` of port `port` ('A'..'L', as the chip has them) to `level` (0/1), or
 * release it (-1). */
int uno_pin_drive(uno_shim_t *s, char port, int bit, int level)
{
	return pins_error(pins_drive(&s->pins, port, bit, level));
}

/* The same at cycle `at`: UNO_ERR_PAST if it has gone. */
int uno_pin_schedule(uno_shim_t *s, char port, int bit, uint64_t at, int level)
{
	return pins_error(pins_schedule(&s->pins, port, bit, at, level));
}

/* Scheduled levels not applied yet. */
size_t uno_pin_scheduled(const uno_shim_t *s)
{
	return pins_scheduled(&s->pins);
}

/* The level pin P`port``bit` shows (an output's, with a compare output; an input's PINx), or
 * UNO_ERR_ARG. */
int uno_pin_level(const uno_shim_t *s, char port, int bit)
{
	int level = pins_level(&s->pins, port, bit);
	return level < 0 ? UNO_ERR_ARG : level;
}

/* Logs the level changes of output P`port``bit`; `level`: its level now. */
int uno_pin_log(uno_shim_t *s, char port, int bit, int *level)
{
	return pins_error(pins_log(&s->pins, port, bit, level));
}

/* Moves up to `max` logged changes of P`port``bit` to `out`: how many, or UNO_ERR_ARG. */
long uno_pin_log_take(uno_shim_t *s, char port, int bit, pin_edge_t *out, size_t max)
{
	long n = pins_take_log(&s->pins, port, bit, out, max);
	return n < 0 ? UNO_ERR_ARG : n;
}

int uno_adc_set(uno_shim_t *s, int channel, uint32_t millivolts)
{
	if (channel < 0 || channel > 15)
		return UNO_ERR_ARG;
	avr_irq_t *irq = avr_io_getirq(s->avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0 + channel);
	if (!irq)
		return UNO_ERR_ARG;
	avr_raise_irq(irq, millivolts);
	return UNO_OK;
}

void uno_set_aref(uno_shim_t *s, uint32_t millivolts)
{
	s->avr->aref = millivolts;
}

/* EEPROM size in bytes (E2END + 1). */
uint32_t uno_eeprom_size(const uno_shim_t *s)
{
	return (uint32_t)s->avr->e2end + 1;
}

/* Copy `len` EEPROM bytes from `offset` to `out` (simavr's AVR_IOCTL_EEPROM_GET). */
int uno_eeprom_read(uno_shim_t *s, uint32_t offset, uint8_t *out, uint32_t len)
{
	if ((uint64_t)offset + len > uno_eeprom_size(s))
		return UNO_ERR_ARG;
	if (len == 0)
		return UNO_OK;
	avr_eeprom_desc_t d = { .ee = out, .offset = (uint16_t)offset, .size = len };
	avr_ioctl(s->avr, AVR_IOCTL_EEPROM_GET, &d);
	return UNO_OK;
}

/* Overwrite `len` EEPROM bytes from `offset` (simavr's AVR_IOCTL_EEPROM_SET). */
int uno_eeprom_write(uno_shim_t *s, uint32_t offset, const uint8_t *in, uint32_t len)
{
	if ((uint64_t)offset + len > uno_eeprom_size(s))
		return UNO_ERR_ARG;
	if (len == 0)
		return UNO_OK;
	avr_eeprom_desc_t d = { .ee = (uint8_t *)in, .offset = (uint16_t)offset, .size = len };
	avr_ioctl(s->avr, AVR_IOCTL_EEPROM_SET, &d);
	return UNO_OK;
}

uint32_t uno_flash_size(const uno_shim_t *s)
{
	return (uint32_t)s->avr->flashend + 1;
}

/* Copy `len` flash bytes from byte address `offset` to `out`. */
int uno_flash_read(const uno_shim_t *s, uint32_t offset, uint8_t *out, uint32_t len)
{
	if ((uint64_t)offset + len > uno_flash_size(s))
		return UNO_ERR_ARG;
	memcpy(out, s->avr->flash + offset, len);
	return UNO_OK;
}

/* Program `len` flash bytes at byte address `offset` (as a programmer would). */
int uno_flash_write(uno_shim_t *s, uint32_t offset, const uint8_t *in, uint32_t len)
{
	if ((uint64_t)offset + len > uno_flash_size(s))
		return UNO_ERR_ARG;
	memcpy(s->avr->flash + offset, in, len);
	return UNO_OK;
}

/* Where the core starts after a reset: 0, or the boot section's start (BOOTRST). */
void uno_set_reset_address(uno_shim_t *s, uint32_t byte_address)
{
	s->avr->reset_pc = byte_address;
}

/* An external or power-on reset: `cause` is MCUSR's bits for it (PORF 1, EXTRF 2). */
void uno_reset(uno_shim_t *s, uint8_t cause)
{
	chip_reset(s, cause);
}

/* Resets since the simulation started, and MCUSR right after the last one. */
uint64_t uno_resets(const uno_shim_t *s, uint8_t *cause)
{
	*cause = s->reset_cause;
	return s->resets;
}

/* Attaches a part to the SPI port (spi.c), its chip select on pin P`port``bit`; `fn` is
 * called with `ctx` for every byte and chip-select change. Once per instance. */
int uno_spi_attach(uno_shim_t *s, char port, int bit, spi_part_fn fn, void *ctx)
{
	if (s->spi_part.fn)
		return UNO_ERR_ARG;
	return spi_attach_part(s->avr, &s->spi_part, port, bit, fn, ctx) ? UNO_ERR_ARG : UNO_OK;
}

/* The SPI part's INT line drives pin P`port``bit` (as an external driver, uno_pin_drive). */
static void drive_spi_int(void *harness, int level)
{
	uno_shim_t *s = harness;
	uno_pin_drive(s, s->spi_int_port, s->spi_int_bit, level);
}

/* EIMSK written: an external interrupt in low-level mode enabled while its pin is low fires,
 * as on the chip. simavr sets INTFn when its pin falls with the interrupt masked (the
 * chip never sets it in level mode) and then, the flag being up, never raises it again: a
 * firmware that masks the interrupt while it serves the line would wait for ever. */
static void eimsk_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
	avr->data[addr] = v;
	avr_extint_t *p = param;
	for (int n = 0; n < EXTINT_COUNT && p->eint[n].port_ioctl; n++) {
		if (!p->eint[n].isc[1].reg || avr_regbit_get_array(avr, p->eint[n].isc, 2) != 0)
			continue; /* not a level interrupt */
		avr_regbit_clear(avr, p->eint[n].vector.raised);
		if (!avr_regbit_get(avr, p->eint[n].vector.enable))
			continue;
		avr_ioport_state_t state;
		if (avr_ioctl(avr, AVR_IOCTL_IOPORT_GETSTATE(p->eint[n].port_ioctl & 0xFF), &state) < 0)
			continue;
		if (!((state.pin >> p->eint[n].port_pin) & 1))
			avr_raise_interrupt(avr, &p->eint[n].vector);
	}
}

/* Wires the SPI part's INT line to pin P`port``bit`, and has every external interrupt
 * fire again and again while its pin is held low in low-level mode, as the chip's do
 * (simavr fires once per falling edge otherwise). After uno_spi_attach. */
int uno_spi_int(uno_shim_t *s, char port, int bit)
{
	if (!s->spi_part.fn || bit < 0 || bit > 7 || !pins_port(&s->pins, port))
		return UNO_ERR_ARG;
	s->spi_int_port = port;
	s->spi_int_bit = bit;
	s->spi_part.harness = s;
	s->spi_part.drive_int = drive_spi_int;
	for (uint8_t n = 0; n < 8; n++)
		avr_extint_set_strict_lvl_trig(s->avr, n, 1);
	for (avr_io_t *io = s->avr->io_port; io; io = io->next)
		if (!strcmp(io->kind, "extint")) {
			avr_extint_t *p = (avr_extint_t *)io;
			avr_register_io_write(s->avr, p->eint[0].vector.enable.reg, eimsk_write, p);
		}
	spi_part_update_int(&s->spi_part);
	return UNO_OK;
}

/* The SPI part's INT line brought up to date (after the harness changed the part). */
void uno_spi_sync(uno_shim_t *s)
{
	spi_part_update_int(&s->spi_part);
}
