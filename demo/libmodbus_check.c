/*
 * Polls the firmware on a (virtual) Uno with libmodbus, the library behind mbpoll and
 * QModMaster, and checks every answer: function codes 01 02 03 04 05 06 15 16, exceptions
 * 01, 02 and 03 (raw requests mbpoll cannot send), a broadcast write read back afterwards,
 * then N back-to-back reads with the answer rate.
 *
 *   cc -o libmodbus_check libmodbus_check.c $(pkg-config --cflags --libs libmodbus)
 *   libmodbus_check PORT BAUD PARITY(N|E|O) STOPBITS [READS]
 *
 * Needs registers 40001-40010 (not 40011), coils 00001-00005, input 10001 and 30001: true of
 * the uno_slave and dip_switch examples. Prints one line per step; exits 1 if any failed.
 */
#include <errno.h>
#include <modbus.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static int failed;

static void report(int ok, const char *step, const char *got)
{
	printf("%s %s: %s\n", ok ? "ok  " : "FAIL", step, got);
	fflush(stdout);
	if (!ok)
		failed++;
}

/* A call returning -1 on error: "ok" or libmodbus's message. */
static void expect_ok(int rc, const char *step)
{
	report(rc != -1, step, rc != -1 ? "ok" : modbus_strerror(errno));
}

static void expect_regs(modbus_t *ctx, int addr, int n, const uint16_t *want, const char *step)
{
	uint16_t got[16] = {0};
	char text[128] = "";
	if (modbus_read_registers(ctx, addr, n, got) != n) {
		report(0, step, modbus_strerror(errno));
		return;
	}
	for (int i = 0; i < n; i++)
		snprintf(text + strlen(text), sizeof text - strlen(text), "%s%u", i ? " " : "", got[i]);
	report(memcmp(got, want, n * sizeof *got) == 0, step, text);
}

/* Sends a raw request (slave id, PDU) and expects exception `code`: slave, FC | 0x80, code. */
static void expect_exception(modbus_t *ctx, const uint8_t *req, int len, int code, const char *step)
{
	uint8_t rsp[MODBUS_RTU_MAX_ADU_LENGTH];
	char text[64];
	int rc = modbus_send_raw_request(ctx, req, len);
	if (rc != -1)
		rc = modbus_receive_confirmation(ctx, rsp);
	int got = rc >= 3 && rsp[1] == (req[1] | 0x80) ? rsp[2] : 0;
	if (got)
		snprintf(text, sizeof text, "exception %02d", got);
	else
		snprintf(text, sizeof text, "no exception (%s)", rc == -1 ? modbus_strerror(errno) : "normal answer");
	report(got == code, step, text);
}

int main(int argc, char **argv)
{
	if (argc < 5) {
		fprintf(stderr, "usage: %s PORT BAUD PARITY(N|E|O) STOPBITS [READS]\n", argv[0]);
		return 2;
	}
	int reads = argc > 5 ? atoi(argv[5]) : 0;
	modbus_t *ctx = modbus_new_rtu(argv[1], atoi(argv[2]), argv[3][0], 8, atoi(argv[4]));
	if (!ctx || modbus_set_slave(ctx, 1) == -1 || modbus_connect(ctx) == -1) {
		printf("FAIL cannot open %s: %s\n", argv[1], modbus_strerror(errno));
		return 1;
	}
	modbus_set_response_timeout(ctx, 1, 0);
	printf("libmodbus %s: %s at %s 8%c%s, slave 1\n", LIBMODBUS_VERSION_STRING, argv[1], argv[2], argv[3][0],
	       argv[4]);

	uint16_t three[] = {7, 8, 9}, one[] = {4660};
	expect_ok(modbus_write_registers(ctx, 2, 3, three), "FC16 write 40003-40005 = 7 8 9");
	expect_regs(ctx, 2, 3, three, "FC03 read back 40003-40005");
	expect_ok(modbus_write_register(ctx, 5, 4660), "FC06 write 40006 = 4660");
	expect_regs(ctx, 5, 1, one, "FC03 read back 40006");

	uint8_t bits[] = {1, 0, 1}, got_bits[5] = {0};
	expect_ok(modbus_write_bits(ctx, 1, 3, bits), "FC15 write coils 00002-00004 = 1 0 1");
	expect_ok(modbus_write_bit(ctx, 4, 1), "FC05 write coil 00005 on");
	int n = modbus_read_bits(ctx, 0, 5, got_bits);
	char text[64];
	snprintf(text, sizeof text, "%d %d %d %d %d", got_bits[0], got_bits[1], got_bits[2], got_bits[3], got_bits[4]);
	report(n == 5 && !memcmp(got_bits + 1, (uint8_t[]){1, 0, 1, 1}, 4), "FC01 read back coils 00001-00005",
	       n == 5 ? text : modbus_strerror(errno));
	expect_ok(modbus_read_input_bits(ctx, 0, 1, got_bits), "FC02 read discrete input 10001");
	expect_ok(modbus_read_input_registers(ctx, 0, 1, one), "FC04 read input register 30001");

	expect_exception(ctx, (uint8_t[]){1, 0x2b, 0x0e, 0x01, 0x00}, 5, 1, "FC43 read device identification (not supported)");
	expect_exception(ctx, (uint8_t[]){1, 0x03, 0x00, 0x0a, 0x00, 0x01}, 6, 2, "FC03 read 40011 (missing)");
	expect_exception(ctx, (uint8_t[]){1, 0x03, 0x00, 0x00, 0x00, 0x7e}, 6, 3, "FC03 read 126 registers");

	/* libmodbus 3.1.6 waits for an answer to a broadcast too: send it raw instead. */
	uint16_t broadcast[] = {4321};
	expect_ok(modbus_send_raw_request(ctx, (uint8_t[]){0, 0x06, 0x00, 0x09, 0x10, 0xe1}, 6),
		  "broadcast FC06 40010 = 4321 (no answer expected)");
	usleep(50000);
	expect_regs(ctx, 9, 1, broadcast, "FC03 read back 40010 from slave 1");

	if (reads > 0) {
		struct timespec t0, t1;
		int answered = 0;
		clock_gettime(CLOCK_MONOTONIC, &t0);
		for (int i = 0; i < reads; i++)
			answered += modbus_read_registers(ctx, 0, 1, one) == 1;
		clock_gettime(CLOCK_MONOTONIC, &t1);
		double took = (t1.tv_sec - t0.tv_sec) + (t1.tv_nsec - t0.tv_nsec) / 1e9;
		printf("%s %d back-to-back FC03 reads: %d answered (%.1f %%) in %.1f s (%.1f ms each)\n",
		       answered == reads ? "ok  " : "FAIL", reads, answered, 100.0 * answered / reads, took,
		       1000.0 * took / reads);
		failed += answered != reads;
	}
	modbus_close(ctx);
	modbus_free(ctx);
	if (failed)
		printf("%d step(s) failed\n", failed);
	return failed ? 1 : 0;
}
