/*
 * Test firmware for uno-sim's WIZnet shield: a TCP echo server on port 7 on every socket of a
 * W5100 (default) or a W5500 (-DW5500), polling, SPI at fosc/2, the chip select on PB2.
 *
 * It reads 16-bit registers the way WIZnet advises (twice, until both reads agree), moves at
 * most 64 bytes per turn and waits for SEND_OK after each SEND. `turns` counts main-loop
 * turns, `echoed` the bytes echoed.
 */
#include <avr/io.h>
#include <stdint.h>

#define SOCKETS 4
#define PORT 7

#define SN_MR 0x00
#define SN_CR 0x01
#define SN_IR 0x02
#define SN_SR 0x03
#define SN_PORT 0x04
#define SN_TX_FSR 0x20
#define SN_TX_WR 0x24
#define SN_RX_RSR 0x26
#define SN_RX_RD 0x28

#define OPEN 0x01
#define LISTEN 0x02
#define DISCON 0x08
#define SEND 0x20
#define RECV 0x40

#define CLOSED 0x00
#define ESTABLISHED 0x17
#define CLOSE_WAIT 0x1C

#define SEND_OK 0x10

volatile uint8_t ready, version;
volatile uint16_t turns, echoed;

static uint8_t xfer(uint8_t b)
{
	SPDR = b;
	while (!(SPSR & _BV(SPIF)))
		;
	return SPDR;
}

static void select(void) { PORTB &= ~_BV(PB2); }
static void deselect(void) { PORTB |= _BV(PB2); }

#ifdef W5500
static void access(uint8_t block, uint16_t addr, uint8_t *p, uint8_t n, uint8_t write)
{
	select();
	xfer(addr >> 8);
	xfer(addr);
	xfer(block << 3 | (write ? 4 : 0));
	while (n--) {
		uint8_t v = xfer(write ? *p : 0);
		if (!write)
			*p = v;
		p++;
	}
	deselect();
}
static void sock_rw(uint8_t s, uint8_t off, uint8_t *p, uint8_t n, uint8_t w) { access(4 * s + 1, off, p, n, w); }
static void tx_write(uint8_t s, uint16_t ptr, uint8_t *p, uint8_t n) { access(4 * s + 2, ptr, p, n, 1); }
static void rx_read(uint8_t s, uint16_t ptr, uint8_t *p, uint8_t n) { access(4 * s + 3, ptr, p, n, 0); }
static uint8_t common_read(uint16_t addr) { uint8_t v; access(0, addr, &v, 1, 0); return v; }
static void common_write(uint16_t addr, uint8_t v) { access(0, addr, &v, 1, 1); }
#define VERSION_REG 0x39
#else
static uint8_t frame(uint8_t op, uint16_t addr, uint8_t v)
{
	select();
	xfer(op);
	xfer(addr >> 8);
	xfer(addr);
	v = xfer(v);
	deselect();
	return v;
}
static uint8_t common_read(uint16_t addr) { return frame(0x0F, addr, 0); }
static void common_write(uint16_t addr, uint8_t v) { frame(0xF0, addr, v); }
static void sock_rw(uint8_t s, uint8_t off, uint8_t *p, uint8_t n, uint8_t w)
{
	for (uint16_t a = 0x400 + s * 0x100 + off; n--; a++, p++)
		if (w)
			frame(0xF0, a, *p);
		else
			*p = frame(0x0F, a, 0);
}
static void tx_write(uint8_t s, uint16_t ptr, uint8_t *p, uint8_t n)
{
	while (n--)
		frame(0xF0, 0x4000 + s * 0x800 + (ptr++ & 0x7FF), *p++);
}
static void rx_read(uint8_t s, uint16_t ptr, uint8_t *p, uint8_t n)
{
	while (n--)
		*p++ = frame(0x0F, 0x6000 + s * 0x800 + (ptr++ & 0x7FF), 0);
}
#define VERSION_REG 0x1B /* TMSR: 0x55 after reset */
#endif

static uint8_t sock_read(uint8_t s, uint8_t off) { uint8_t v; sock_rw(s, off, &v, 1, 0); return v; }
static void sock_write(uint8_t s, uint8_t off, uint8_t v) { sock_rw(s, off, &v, 1, 1); }

static uint16_t read16(uint8_t s, uint8_t off)
{
	uint8_t a[2], b[2];
	do {
		sock_rw(s, off, a, 2, 0);
		sock_rw(s, off, b, 2, 0);
	} while (a[0] != b[0] || a[1] != b[1]);
	return (uint16_t)a[0] << 8 | a[1];
}

static void write16(uint8_t s, uint8_t off, uint16_t v)
{
	uint8_t a[2] = { v >> 8, v };
	sock_rw(s, off, a, 2, 1);
}

static void command(uint8_t s, uint8_t c)
{
	sock_write(s, SN_CR, c);
	while (sock_read(s, SN_CR))
		;
}

static void listen(uint8_t s)
{
	sock_write(s, SN_MR, 0x01);
	write16(s, SN_PORT, PORT);
	command(s, OPEN);
	command(s, LISTEN);
}

static void echo(uint8_t s)
{
	uint8_t buf[64];
	uint16_t n = read16(s, SN_RX_RSR);
	if (n == 0)
		return;
	if (n > sizeof(buf))
		n = sizeof(buf);
	uint16_t free = read16(s, SN_TX_FSR);
	if (free < n)
		return;
	uint16_t rd = read16(s, SN_RX_RD);
	rx_read(s, rd, buf, n);
	write16(s, SN_RX_RD, rd + n);
	command(s, RECV);
	uint16_t wr = read16(s, SN_TX_WR);
	tx_write(s, wr, buf, n);
	write16(s, SN_TX_WR, wr + n);
	command(s, SEND);
	while (!(sock_read(s, SN_IR) & SEND_OK))
		if (sock_read(s, SN_SR) == CLOSED)
			return;
	sock_write(s, SN_IR, SEND_OK);
	echoed += n;
}

int main(void)
{
	DDRB |= _BV(PB2) | _BV(PB3) | _BV(PB5);
	deselect();
	SPCR = _BV(SPE) | _BV(MSTR);
	SPSR = _BV(SPI2X);
	common_write(0x0000, 0x80); /* MR: software reset */
	version = common_read(VERSION_REG);
	for (uint8_t s = 0; s < SOCKETS; s++)
		listen(s);
	ready = 1;
	for (;;) {
		turns++;
		for (uint8_t s = 0; s < SOCKETS; s++) {
			uint8_t sr = sock_read(s, SN_SR);
			if (sr == CLOSED) {
				listen(s);
			} else if (sr == ESTABLISHED || sr == CLOSE_WAIT) {
				echo(s);
				if (sr == CLOSE_WAIT && read16(s, SN_RX_RSR) == 0)
					command(s, DISCON);
			}
		}
	}
}
