/*
 * Polls the four slave ids of examples/units.rs (one board standing in for four sensors,
 * ids 1-4) with libmodbus, switching ids with modbus_set_slave as a master polling several
 * slaves on one line does, and checks every answer: each id's own reading and writes, a
 * broadcast write reaching all four, silence from id 5, then N reads over ids 1-4 in turn.
 *
 *   cc -o libmodbus_units_check libmodbus_units_check.c $(pkg-config --cflags --libs libmodbus)
 *   libmodbus_units_check PORT BAUD PARITY(N|E|O) STOPBITS [READS]
 *
 * Prints one line per step; exits 1 if any failed.
 */
#include <errno.h>
#include <modbus.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static int failed;

static void report(int ok, const char *step, const char *got)
{
	printf("%s %s: %s\n", ok ? "ok  " : "FAIL", step, got);
	fflush(stdout);
	if (!ok)
		failed++;
}

/* Reads `n` registers (input when `input`) from `addr` of slave `id`, expects `want`. */
static void expect(modbus_t *ctx, int id, int input, int addr, int n, const uint16_t *want, const char *what)
{
	uint16_t got[8] = {0};
	char step[96], text[64] = "";
	snprintf(step, sizeof step, "slave %d: %s", id, what);
	modbus_set_slave(ctx, id);
	int rc = input ? modbus_read_input_registers(ctx, addr, n, got) : modbus_read_registers(ctx, addr, n, got);
	if (rc != n) {
		report(0, step, modbus_strerror(errno));
		return;
	}
	for (int i = 0; i < n; i++)
		snprintf(text + strlen(text), sizeof text - strlen(text), "%s%u", i ? " " : "", got[i]);
	report(memcmp(got, want, n * sizeof *got) == 0, step, text);
}

int main(int argc, char **argv)
{
	if (argc < 5) {
		fprintf(stderr, "usage: %s PORT BAUD PARITY(N|E|O) STOPBITS [READS]\n", argv[0]);
		return 2;
	}
	int reads = argc > 5 ? atoi(argv[5]) : 0;
	modbus_t *ctx = modbus_new_rtu(argv[1], atoi(argv[2]), argv[3][0], 8, atoi(argv[4]));
	if (!ctx || modbus_connect(ctx) == -1) {
		printf("FAIL cannot open %s: %s\n", argv[1], modbus_strerror(errno));
		return 1;
	}
	modbus_set_response_timeout(ctx, 0, 500000);
	printf("libmodbus %s: %s at %s 8%c%s, slaves 1-4\n", LIBMODBUS_VERSION_STRING, argv[1], argv[2], argv[3][0],
	       argv[4]);

	for (int id = 1; id <= 4; id++) {
		uint16_t reading[] = {100 * id};
		expect(ctx, id, 1, 0, 1, reading, "FC04 read 30001 (its reading)");
	}
	uint16_t none[1];
	modbus_set_slave(ctx, 5);
	int rc = modbus_read_input_registers(ctx, 0, 1, none);
	report(rc == -1 && errno == ETIMEDOUT, "slave 5: FC04 read 30001 (no such slave)",
	       rc == -1 ? modbus_strerror(errno) : "answered");

	for (int id = 1; id <= 4; id++) {
		char step[64];
		snprintf(step, sizeof step, "slave %d: FC16 write 40001-40002 = %d %d", id, 20 + id, 30 + id);
		modbus_set_slave(ctx, id);
		uint16_t values[] = {20 + id, 30 + id};
		rc = modbus_write_registers(ctx, 0, 2, values);
		report(rc == 2, step, rc == 2 ? "ok" : modbus_strerror(errno));
	}
	/* libmodbus 3.1.6 waits for an answer to a broadcast too: send it raw instead. */
	rc = modbus_send_raw_request(ctx, (uint8_t[]){0, 0x06, 0x00, 0x01, 0x00, 0x4d}, 6);
	report(rc != -1, "broadcast FC06 40002 = 77 (no answer expected)", rc != -1 ? "ok" : modbus_strerror(errno));
	usleep(50000);
	for (int id = 1; id <= 4; id++) {
		uint16_t holding[] = {20 + id, 77}, copy[] = {20 + id};
		expect(ctx, id, 0, 0, 2, holding, "FC03 read 40001-40002 after the broadcast");
		expect(ctx, id, 1, 1, 1, copy, "FC04 read 30002 (the firmware's copy of 40001)");
	}

	int answered = 0;
	for (int i = 0; i < reads; i++) {
		uint16_t got[1];
		modbus_set_slave(ctx, 1 + i % 4);
		answered += modbus_read_input_registers(ctx, 0, 1, got) == 1 && got[0] == 100 * (1 + i % 4);
	}
	if (reads > 0) {
		printf("%s %d reads, slaves 1-4 in turn: %d answered right\n", answered == reads ? "ok  " : "FAIL", reads,
		       answered);
		failed += answered != reads;
	}
	modbus_close(ctx);
	modbus_free(ctx);
	if (failed)
		printf("%d step(s) failed\n", failed);
	return failed ? 1 : 0;
}
