/*
 * Test firmware for uno-sim: interrupt-driven USART echo at 19200 baud 8E1.
 *
 * Builds for every chip uno-sim runs (avr-gcc -mmcu=...): -DUSART_N=n picks the USART
 * ( default 0; the 32U4 has only USART1). -DDEBUG_USART=k also sets up USARTk at 9600 8N1
 * and writes "boot\r\n" on it (polling UDREk) before `ready` is set.
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

#ifndef USART_N
#define USART_N 0
#endif

/* USARTn's names: R(UCSR, A) is UCSR0A with USART_N=0; B(RXEN) is RXEN0 */
#define CAT3_(a, n, b) a##n##b
#define CAT3(a, n, b) CAT3_(a, n, b)
#define R(name, suffix) CAT3(name, USART_N, suffix)
#define B(name) CAT3(name, USART_N, )
#define REG_UCSRA R(UCSR, A)
#define REG_UCSRB R(UCSR, B)
#define REG_UCSRC R(UCSR, C)
#define REG_UBRRH R(UBRR, H)
#define REG_UBRRL R(UBRR, L)
#define REG_UDR B(UDR)
/* the 328P and 168 call USART0's vectors USART_RX_vect, the others USARTn_RX_vect */
#if defined(USART_RX_vect) && USART_N == 0
#define RX_VECT USART_RX_vect
#define UDRE_VECT USART_UDRE_vect
#else
#define RX_VECT R(USART, _RX_vect)
#define UDRE_VECT R(USART, _UDRE_vect)
#endif

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
	REG_UCSRB |= _BV(B(UDRIE));
}

static void log_rx(uint8_t status, uint8_t byte)
{
	uint8_t n = rx_count;
	if (n < 64) {
		rx_log[n].byte = byte;
		rx_log[n].status = status & (_BV(B(FE)) | _BV(B(DOR)) | _BV(B(UPE)));
		rx_count = n + 1;
	}
}

ISR(RX_VECT)
{
	uint8_t status = REG_UCSRA;
	uint8_t byte = REG_UDR;
	log_rx(status, byte);
	tx_put(byte);
	if (mode == 2 || mode == 5)
		tx_put(byte);
}

ISR(UDRE_VECT)
{
	if (tx_head == tx_tail) {
		REG_UCSRB &= ~_BV(B(UDRIE));
		return;
	}
	REG_UDR = tx_buf[tx_tail];
	tx_tail = (tx_tail + 1) & 127;
}

#ifdef DEBUG_USART
#define D(name, suffix) CAT3(name, DEBUG_USART, suffix)
/* Writes `text` on USARTk, polling UDREk. */
static void debug_print(const char *text)
{
	D(UBRR, H) = 0;
	D(UBRR, L) = 103; /* 9600 baud at 16 MHz */
	D(UCSR, C) = _BV(CAT3(UCSZ, DEBUG_USART, 1)) | _BV(CAT3(UCSZ, DEBUG_USART, 0));
	D(UCSR, B) = _BV(CAT3(TXEN, DEBUG_USART, ));
	for (; *text; text++) {
		while (!(D(UCSR, A) & _BV(CAT3(UDRE, DEBUG_USART, ))))
			;
		CAT3(UDR, DEBUG_USART, ) = *text;
	}
}
#endif

int main(void)
{
	/* pin 13 (PB5) output low, pin 8 (PB0) output high */
	DDRB = _BV(PB5) | _BV(PB0);
	PORTB = _BV(PB0);
	/* pin 2 (PD2) input with pull-up; A1 (PC1) plain input */
	PORTD = _BV(PD2);

	if (mode != 5)
		REG_UCSRC = _BV(R(UPM, 1)) | _BV(R(UCSZ, 1)) | _BV(R(UCSZ, 0)); /* 8E1, before UBRRn */
	REG_UBRRH = 0;
	REG_UBRRL = 51; /* 19200 baud at 16 MHz, U2Xn = 0 */
	if (mode == 5)
		REG_UCSRC = _BV(R(UCSZ, 1)) | _BV(R(UCSZ, 0)); /* 8N1, after UBRRn */
	REG_UCSRB = _BV(B(RXEN)) | _BV(B(TXEN)) | (mode == 3 ? 0 : _BV(B(RXCIE)));
#ifdef DEBUG_USART
	debug_print("boot\r\n");
#endif

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
				REG_UCSRA = _BV(B(TXC));
				clear_txc = 0;
			}
			if (drain) {
				while (REG_UCSRA & _BV(B(RXC))) {
					uint8_t status = REG_UCSRA;
					log_rx(status, REG_UDR);
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
