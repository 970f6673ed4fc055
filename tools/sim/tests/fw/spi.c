/*
 * Test firmware for uno-sim's SPI timing: one SPI byte each time the host sets `go`, as a
 * master, with SPCR's SPR1:0 from `spr` and SPSR's SPI2X from `spi2x` (set by the host).
 * PB2 (pin 10) is the chip select, low around the byte. The byte sent is `tx`, the byte
 * read back goes to `rx`; `done` counts the bytes.
 */
#include <avr/io.h>
#include <stdint.h>

volatile uint8_t ready, go, done, tx, rx, spr, spi2x;

int main(void)
{
	DDRB |= _BV(PB2) | _BV(PB3) | _BV(PB5);
	PORTB |= _BV(PB2);
	ready = 1;
	for (;;) {
		while (!go)
			;
		go = 0;
		SPCR = _BV(SPE) | _BV(MSTR) | (spr & 3);
		SPSR = spi2x ? _BV(SPI2X) : 0;
		PORTB &= ~_BV(PB2);
		SPDR = tx;
		while (!(SPSR & _BV(SPIF)))
			;
		rx = SPDR;
		PORTB |= _BV(PB2);
		done++;
	}
}
