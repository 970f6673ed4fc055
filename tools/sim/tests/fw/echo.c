/*
 * Test firmware for uno-sim: interrupt-driven USART0 echo at 19200 baud 8E1.
 *
 * UCSR0C is written *before* UBRR0 (simavr 1.6 only reads the frame format when
 * UBRR0L is written, so this order catches a simulator that trusts simavr's timing).
 *
 * mode (set by the host before the first instruction, kept in .noinit):
 *   0: echo every byte; the idle loop polls pin 2 and the ADC.
 *   1: echo every byte; the idle loop sleeps (idle mode).
 *   2: echo every byte twice (the transmit buffer fills up); idle loop sleeps.
 *   3: no RX interrupt; once `drain` is set, read everything the USART holds;
 *      `clear_txc` makes it write UCSR0A (to clear TXC0) once.
 *   4: sleep with interrupts disabled (simavr then stops the simulation).
 *   5: like 2, but 8N1 and UCSR0C written *after* UBRR0 (simavr would time 11 bits).
 * Every received byte is logged with the UCSR0A error bits seen just before reading UDR0.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdint.h>

struct rx_rec {
	uint8_t byte;
	uint8_t status;
};

uint8_t mode __attribute__((section(".noinit")));
volatile uint8_t ready;
volatile uint8_t drain;
volatile uint8_t clear_txc;
volatile struct rx_rec rx_log[64];
volatile uint8_t rx_count;
volatile uint8_t tx_buf[128];
volatile uint8_t tx_head, tx_tail;
volatile uint16_t adc_values[6];
volatile uint16_t loops;

static void tx_put(uint8_t b)
{
	tx_buf[tx_head] = b;
	tx_head = (tx_head + 1) & 127;
	UCSR0B |= _BV(UDRIE0);
}

static void log_rx(uint8_t status, uint8_t byte)
{
	uint8_t n = rx_count;
	if (n < 64) {
		rx_log[n].byte = byte;
		rx_log[n].status = status & (_BV(FE0) | _BV(DOR0) | _BV(UPE0));
		rx_count = n + 1;
	}
}

ISR(USART_RX_vect)
{
	uint8_t status = UCSR0A;
	uint8_t byte = UDR0;
	log_rx(status, byte);
	tx_put(byte);
	if (mode == 2 || mode == 5)
		tx_put(byte);
}

ISR(USART_UDRE_vect)
{
	if (tx_head == tx_tail) {
		UCSR0B &= ~_BV(UDRIE0);
		return;
	}
	UDR0 = tx_buf[tx_tail];
	tx_tail = (tx_tail + 1) & 127;
}

int main(void)
{
	/* pin 13 (PB5) output low, pin 8 (PB0) output high */
	DDRB = _BV(PB5) | _BV(PB0);
	PORTB = _BV(PB0);
	/* pin 2 (PD2) input with pull-up; A1 (PC1) plain input */
	PORTD = _BV(PD2);

	if (mode != 5)
		UCSR0C = _BV(UPM01) | _BV(UCSZ01) | _BV(UCSZ00); /* 8E1, before UBRR0 */
	UBRR0H = 0;
	UBRR0L = 51; /* 19200 baud at 16 MHz, U2X0 = 0 */
	if (mode == 5)
		UCSR0C = _BV(UCSZ01) | _BV(UCSZ00); /* 8N1, after UBRR0 */
	UCSR0B = _BV(RXEN0) | _BV(TXEN0) | (mode == 3 ? 0 : _BV(RXCIE0));

	ADMUX = _BV(REFS0); /* AVCC reference, channel 0 */
	ADCSRA = _BV(ADEN) | _BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0);

	set_sleep_mode(SLEEP_MODE_IDLE);
	sei();
	ready = 1;
	if (mode == 4) {
		cli();
		sleep_enable();
		sleep_cpu();
	}

	uint8_t ch = 0;
	for (;;) {
		if (mode == 1 || mode == 2 || mode == 5) {
			sleep_enable();
			sleep_cpu();
			sleep_disable();
			continue;
		}
		if (mode == 3) {
			if (clear_txc) {
				UCSR0A = _BV(TXC0);
				clear_txc = 0;
			}
			if (drain) {
				while (UCSR0A & _BV(RXC0)) {
					uint8_t status = UCSR0A;
					log_rx(status, UDR0);
				}
				drain = 0;
			}
			continue;
		}
		loops++;
		if (PIND & _BV(PD2))
			PORTB &= ~_BV(PB5);
		else
			PORTB |= _BV(PB5);
		ADMUX = _BV(REFS0) | ch;
		ADCSRA |= _BV(ADSC);
		while (ADCSRA & _BV(ADSC))
			;
		adc_values[ch] = ADC;
		ch = ch == 5 ? 0 : ch + 1;
	}
}
