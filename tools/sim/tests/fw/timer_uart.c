/*
 * Test firmware for uno-sim's 16-bit timer model, as a serial line built on a timer
 * (AltSoftSerial's design): the timer free-running in normal mode, its input capture unit on
 * the RX pin, its output compare unit A on the TX pin.
 *
 * -DTIMER=1 (default): Timer1 on the ATmega328P/168, RX ICP1 = PB0 (pin 8), TX OC1A = PB1
 * (pin 9). -DTIMER=3: Timer3 on the ATmega32U4, ICP3 = PC7, OC3A = PC6. -DTIMER=5: Timer5 on
 * the ATmega2560/1280, ICP5 = PL1, OC5A = PL3.
 *
 * At start-up: RX an input with its pull-up, TX an output driving high (PORT), the timer
 * stopped, interrupts on; then `ready` = 1. The host sets `arg` and then `command`; the main
 * loop runs the command and clears `command`:
 *   START    TCCRnA = 0, TCCRnB = arg (clock select, ICNCn, ICESn), the capture interrupt on
 *   COMPARE  TCCRnA = COMnA from arg's top byte (bits 7:6); OCRnA = arg's low 16 bits, high
 *            byte first (through TEMP, as the datasheet asks)
 *   COMPARE_LOW_FIRST  the same, OCRnAL written before OCRnAH (the wrong order)
 *   FORCE    TCCRnC = FOCnA: a compare match's action on OCnA without a match
 *   TX_OUTPUT  DDR of the TX pin = arg (0: input, 1: output)
 *   PORT     the TX pin's PORT register = arg (the whole byte, as a program toggling another
 *            pin of the port would write it)
 *   READ     `tcnt` = TCNTn, then `ocr` = OCRnA (16-bit reads, low byte first), `tx_pins` =
 *            the TX pin's PIN register
 *   ECHO     replay every captured edge on TX: the OCnA latch set high (COMnA set, FOCnA)
 *            while TX is an input (its pull-up holding the line high), then TX an output; each
 *            capture schedules its edge `ECHO_TICKS` later (COMnA set or clear, OCRnA), the
 *            compare interrupt the next one
 *
 * Every capture interrupt logs ICRn and whether ICESn selected the rising edge into
 * `captures`; with `toggle_edge` set it then flips ICESn, as a serial receiver does.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <stdint.h>

#ifndef TIMER
#define TIMER 1
#endif

#define CAT_(a, n, b) a##n##b
#define CAT(a, n, b) CAT_(a, n, b)
#define TCCRA CAT(TCCR, TIMER, A)
#define TCCRB CAT(TCCR, TIMER, B)
#define TCCRC CAT(TCCR, TIMER, C)
#define TCNT CAT(TCNT, TIMER, )
#define OCRA CAT(OCR, TIMER, A)
#define OCRAL CAT(OCR, TIMER, AL)
#define OCRAH CAT(OCR, TIMER, AH)
#define ICR CAT(ICR, TIMER, )
#define TIMSK CAT(TIMSK, TIMER, )
#define TIFR CAT(TIFR, TIMER, )
#define ICES CAT(ICES, TIMER, )
#define ICIE CAT(ICIE, TIMER, )
#define OCIEA CAT(OCIE, TIMER, A)
#define OCFA CAT(OCF, TIMER, A)
#define FOCA CAT(FOC, TIMER, A)
#define COMA0 CAT(COM, TIMER, A0)

#if TIMER == 1
#define RX_PORT PORTB
#define RX_BIT PB0
#define TX_DDR DDRB
#define TX_PORT PORTB
#define TX_PIN PINB
#define TX_BIT PB1
#define CAPT_vect TIMER1_CAPT_vect
#define COMPA_vect TIMER1_COMPA_vect
#elif TIMER == 3
#define RX_PORT PORTC
#define RX_BIT PC7
#define TX_DDR DDRC
#define TX_PORT PORTC
#define TX_PIN PINC
#define TX_BIT PC6
#define CAPT_vect TIMER3_CAPT_vect
#define COMPA_vect TIMER3_COMPA_vect
#elif TIMER == 5
#define RX_PORT PORTL
#define RX_BIT PL1
#define TX_DDR DDRL
#define TX_PORT PORTL
#define TX_PIN PINL
#define TX_BIT PL3
#define CAPT_vect TIMER5_CAPT_vect
#define COMPA_vect TIMER5_COMPA_vect
#endif

#define COM_SET (3 << COMA0)
#define COM_CLEAR (2 << COMA0)

enum { START = 1, COMPARE, COMPARE_LOW_FIRST, FORCE, TX_OUTPUT, PORT, READ, ECHO };

/* Timer ticks (0.5 us at clk/8) from a captured edge to its replay on TX. */
#define ECHO_TICKS 200
#define CAPTURES 64
#define ECHO_QUEUE 16

struct capture {
	uint16_t icr;
	uint8_t rising;
};

volatile uint8_t ready, command, toggle_edge, capture_count, tx_pins;
volatile uint32_t arg;
volatile uint16_t tcnt, ocr;
volatile struct capture captures[CAPTURES];

static volatile uint8_t echo, echo_busy, echo_head, echo_tail;
static volatile struct capture echo_queue[ECHO_QUEUE];

/* Programs the next replayed edge, or stops the compare interrupt when there is none. */
static void echo_next(void)
{
	if (echo_head == echo_tail) {
		TIMSK &= ~_BV(OCIEA);
		echo_busy = 0;
		return;
	}
	struct capture e = echo_queue[echo_tail++ % ECHO_QUEUE];
	TCCRA = e.rising ? COM_SET : COM_CLEAR;
	OCRA = e.icr;
}

ISR(CAPT_vect)
{
	uint16_t icr = ICR;
	uint8_t rising = (TCCRB & _BV(ICES)) != 0;
	if (toggle_edge)
		TCCRB ^= _BV(ICES);
	if (capture_count < CAPTURES) {
		captures[capture_count].icr = icr;
		captures[capture_count].rising = rising;
		capture_count++;
	}
	if (echo) {
		echo_queue[echo_head++ % ECHO_QUEUE] = (struct capture){ .icr = icr + ECHO_TICKS, .rising = rising };
		if (!echo_busy) {
			echo_busy = 1;
			TIFR = _BV(OCFA);
			echo_next();
			TIMSK |= _BV(OCIEA);
		}
	}
}

ISR(COMPA_vect)
{
	echo_next();
}

static void run(uint8_t cmd, uint32_t a)
{
	switch (cmd) {
	case START:
		TCCRA = 0;
		TCCRB = (uint8_t)a;
		TIMSK = _BV(ICIE);
		break;
	case COMPARE:
		TCCRA = (uint8_t)(a >> 24);
		OCRA = (uint16_t)a;
		break;
	case COMPARE_LOW_FIRST:
		TCCRA = (uint8_t)(a >> 24);
		OCRAL = (uint8_t)a;
		OCRAH = (uint8_t)(a >> 8);
		break;
	case FORCE:
		TCCRC = _BV(FOCA);
		break;
	case TX_OUTPUT:
		if (a)
			TX_DDR |= _BV(TX_BIT);
		else
			TX_DDR &= ~_BV(TX_BIT);
		break;
	case PORT:
		TX_PORT = (uint8_t)a;
		break;
	case READ:
		tcnt = TCNT;
		ocr = OCRA;
		tx_pins = TX_PIN;
		break;
	case ECHO:
		TX_DDR &= ~_BV(TX_BIT);
		TCCRA = COM_SET;
		TCCRC = _BV(FOCA);
		TX_DDR |= _BV(TX_BIT);
		toggle_edge = 1;
		echo = 1;
		break;
	}
}

int main(void)
{
	RX_PORT |= _BV(RX_BIT);
	TX_PORT |= _BV(TX_BIT);
	TX_DDR |= _BV(TX_BIT);
	sei();
	ready = 1;
	for (;;) {
		uint8_t cmd = command;
		if (cmd) {
			run(cmd, arg);
			command = 0;
		}
	}
}
