00000094 <_RINvMNtNtCs57IaH61Jwv1_10avr_modbus5slave6engineINtB3_6EngineKj39_E7processINtNtB5_4bank4BankKj4_Kj18_KB1u_EECskHZFt459qWC_17sixteen_each_bank>:
push	r2
push	r3
push	r4
push	r5
push	r6
push	r7
push	r8
push	r9
push	r10
push	r11
push	r12
push	r13
push	r14
push	r15
push	r16
push	r17
push	r28
push	r29
in	r28, X	
in	r29, X	
sbiw	r28, X	
in	r0, X	
cli
out	X, r29	
out	X, r0	
out	X, r28	
lds	r16, X	
sts	X, r1	
mov	r24, r16
dec	r24
cpi	r24, X	
brcs	REL      	
rjmp	REL    	
lds	r24, X	
mov	r21, r24
subi	r21, XF	
mov	r20, r24
subi	r20, XA	
cpi	r21, X	
brcs	REL      	
mov	r20, r24
mov	r24, r20
subi	r24, X	
lds	r4, XB	
lds	r5, XC	
eor	r4, r5
eor	r5, r4
eor	r4, r5
cpi	r24, 0xFA	
brcc	REL      	
ldi	r17, X	
rjmp	REL    	
cpi	r20, X	
brcs	REL     	
cpi	r20, X	
breq	REL     	
ldi	r24, XB	
ldi	r25, X	
rjmp	REL     	
mov	r24, r20
andi	r24, X	
ldi	r22, X	
cpi	r24, X	
breq	REL      	
ldi	r22, X	
cpi	r20, X	
brcc	REL      	
lsr	r24
mov	r22, r24
cpi	r22, X	
brcs	REL     	
ldi	r24, XD	
ldi	r25, X	
rjmp	REL     	
ldi	r24, 0xB0	
ldi	r25, X	
cpi	r20, X	
mov	r22, r1
breq	REL      	
ldi	r22, X	
cpi	r21, X	
brcs	REL     	
ldi	r26, X	
ldi	r27, X	
ldi	r18, X	
ldi	r19, X	
ldi	r23, X	
rjmp	REL     	
ldi	r24, 0xD0	
ldi	r25, X	
cpi	r21, X	
brcc	REL     	
ldi	r23, X	
cpi	r20, X	
brcc	REL      	
mov	r23, r1
ldi	r26, X	
ldi	r27, X	
rjmp	REL      	
ldi	r26, X	
ldi	r27, X	
mov	r23, r1
movw	r18, r4
movw	r30, r18
sbiw	r30, X	
movw	r6, r30
cp	r30, r24
cpc	r31, r25
brcs	REL      	
rjmp	REL    	
movw	r8, r18
lds	r24, X	
lds	r25, X	
mov	r30, r24
eor	r31, r31
mov	r24, r25
eor	r25, r25
add	r24, r30
adc	r25, r31
cpi	r22, X	
brcc	REL     	
movw	r14, r26
movw	r26, r8
andi	r26, X	
andi	r27, X	
ldi	r30, X	
cp	r26, r1
cpc	r27, r1
brne	REL      	
mov	r30, r1
eor	r31, r31
movw	r12, r8
movw	r10, r12
lsr	r11
ror	r10
lsr	r11
ror	r10
lsr	r11
ror	r10
add	r10, r30
adc	r11, r31
movw	r26, r14
rjmp	REL      	
movw	r12, r8
movw	r10, r12
add	r10, r10
adc	r11, r11
sbiw	r24, X	
cpi	r21, X	
brcc	REL     	
lds	r18, XD	
cp	r18, r10
breq	REL      	
rjmp	REL     	
movw	r30, r10
andi	r31, X	
adiw	r30, X	
cp	r24, r30
cpc	r25, r31
movw	r12, r8
breq	REL     	
rjmp	REL     	
cpi	r24, X	
cpc	r25, r1
breq	REL      	
rjmp	REL     	
cpi	r20, X	
brne	REL     	
ldi	r24, 0xFF	
cp	r4, r1
cpc	r5, r24
breq	REL      	
cp	r4, r1
cpc	r5, r1
breq	REL      	
rjmp	REL     	
movw	r24, r12
neg	r25
neg	r24
sbc	r25, r1
lds	r20, X	
lds	r21, XA	
eor	r20, r21
eor	r21, r20
eor	r20, r21
cp	r24, r20
cpc	r25, r21
brcs	REL      	
rjmp	REL    	
ldi	r17, X	
rjmp	REL      	
ldi	r17, X	
ldi	r24, X	
call	X	
cpi	r16, X	
breq	REL     	
call	X	
ldi	r30, X	
ldi	r31, X	
rjmp	REL     	
sts	X, r17	
lds	r24, X	
ori	r24, X	
sts	X, r24	
ldi	r16, X	
ldi	r17, X	
ldi	r24, X	
call	X	
movw	r24, r16
adiw	r24, X	
sts	X, r25	
sts	X, r24	
movw	r30, r16
adiw	r30, X	
cpi	r16, X	
cpc	r17, r1
brcc	REL     	
movw	r18, r24
subi	r18, 0xF9	
sbci	r19, 0xFE	
movw	r14, r18
movw	r16, r30
call	X	
movw	r30, r14
std	Z+1, r25	
st	Z, r24
movw	r30, r16
sts	X, r31	
sts	X, r30	
movw	r24, r30
adiw	r28, X	
in	r0, X	
cli
out	X, r29	
out	X, r0	
out	X, r28	
pop	r29
pop	r28
pop	r17
pop	r16
pop	r15
pop	r14
pop	r13
pop	r12
pop	r11
pop	r10
pop	r9
pop	r8
pop	r7
pop	r6
pop	r5
pop	r4
pop	r3
pop	r2
ret
cpi	r16, X	
breq	REL     	
cpi	r23, X	
brne	REL      	
ldi	r24, XA	
call	X	
rjmp	REL    	
mov	r18, r16
movw	r24, r10
andi	r25, X	
movw	r16, r24
add	r24, r26
adc	r25, r27
cpi	r24, X	
cpc	r25, r1
brcs	REL      	
ldi	r17, X	
mov	r16, r18
rjmp	REL    	
mov	r11, r18
subi	r26, 0xF8	
sbci	r27, 0xFE	
std	Y+2, r27	
std	Y+1, r26	
ldi	r18, X	
ldi	r19, X	
lds	r30, X	
lds	r31, X	
movw	r14, r18
mov	r24, r1
std	Y+4, r19	
std	Y+3, r18	
movw	r26, r14
subi	r26, 0xAB	
sbci	r27, 0xFE	
cp	r30, r1
cpc	r31, r1
brne	REL      	
rjmp	REL    	
movw	r18, r14
cpi	r18, X	
cpc	r19, r1
brne	REL      	
rjmp	REL    	
movw	r12, r30
ldi	r18, X	
cpi	r22, X	
ldi	r19, X	
brcs	REL      	
mov	r19, r1
movw	r30, r26
ldd	r25, Z+5	
cpi	r25, X	
brcc	REL      	
mov	r18, r1
adiw	r26, X	
movw	r30, r14
adiw	r30, X	
movw	r14, r30
movw	r30, r12
sbiw	r30, X	
cp	r19, r18
movw	r12, r8
breq	REL     	
cp	r25, r22
brcc	REL      	
rjmp	REL     	
cp	r25, r22
breq	REL      	
rjmp	REL     	
movw	r4, r30
movw	r30, r26
ldd	r2, Z+3	
ldd	r3, Z+4	
cp	r2, r20
cpc	r3, r21
brcc	REL      	
rjmp	REL     	
sub	r2, r20
sbc	r3, r21
movw	r30, r26
ldd	r18, Z+1	
ldd	r19, Z+2	
cp	r20, r18
cpc	r21, r19
movw	r12, r8
movw	r30, r4
brcc	REL      	
rjmp	REL    	
movw	r30, r6
cp	r2, r30
cpc	r3, r31
movw	r30, r4
brcc	REL      	
rjmp	REL    	
ldd	r24, Y+3	
ldd	r25, Y+4	
add	r24, r20
adc	r25, r21
sub	r24, r18
sbc	r25, r19
std	Y+4, r25	
std	Y+3, r24	
ldi	r24, X	
rjmp	REL    	
movw	r4, r30
movw	r30, r26
ldd	r2, Z+3	
ldd	r3, Z+4	
movw	r30, r26
ldd	r18, Z+1	
ldd	r19, Z+2	
movw	r30, r2
sub	r30, r18
sbc	r31, r19
ldd	r18, Y+3	
ldd	r19, Y+4	
add	r30, r18
adc	r31, r19
adiw	r30, X	
std	Y+4, r31	
std	Y+3, r30	
movw	r12, r8
movw	r30, r4
rjmp	REL    	
andi	r24, X	
cpi	r24, X	
breq	REL     	
cpi	r22, X	
mov	r24, r11
brcc	REL     	
cpi	r23, X	
movw	r30, r16
brne	REL     	
ldi	r20, X	
ldi	r21, X	
ldi	r18, 0xAA	
ldi	r19, X	
ldi	r16, X	
ldi	r17, X	
ldd	r24, Y+1	
ldd	r25, Y+2	
movw	r22, r30
ldd	r14, Y+3	
ldd	r15, Y+4	
call	X	
rjmp	REL    	
ldi	r17, X	
mov	r16, r11
rjmp	REL    	
mov	r11, r24
ldd	r24, Y+3	
ldd	r25, Y+4	
cpi	r24, X	
cpc	r25, r1
movw	r26, r16
brcc	REL     	
movw	r30, r24
add	r30, r30
adc	r31, r31
subi	r30, X	
sbci	r31, 0xFE	
rjmp	REL     	
ldd	r14, Y+1	
ldd	r15, Y+2	
movw	r24, r14
mov	r22, r1
movw	r20, r30
call	X	
ldi	r24, 0xAA	
ldi	r25, X	
ldi	r22, X	
ldi	r23, X	
ldi	r30, X	
ldi	r31, X	
ldd	r20, Y+3	
ldd	r21, Y+4	
movw	r18, r14
movw	r14, r30
call	X	
movw	r26, r16
rjmp	REL    	
ldi	r30, X	
ldi	r31, X	
ldi	r18, X	
ldi	r19, X	
movw	r4, r18
ldi	r20, X	
ldi	r21, X	
sub	r20, r24
sbc	r21, r25
ldi	r18, X	
cpi	r20, X	
cpc	r21, r1
brcc	REL      	
mov	r18, r1
cpi	r18, X	
brne	REL      	
movw	r4, r20
movw	r20, r26
lsr	r21
ror	r20
cp	r20, r4
cpc	r21, r5
brcs	REL      	
movw	r20, r4
cpi	r23, X	
brne	REL     	
cp	r20, r1
cpc	r21, r1
ldd	r26, Y+1	
ldd	r27, Y+2	
breq	REL     	
add	r20, r20
adc	r21, r21
add	r20, r26
adc	r21, r27
ld	r18, X+
ld	r19, X+
std	Z+1, r19	
st	Z, r18
adiw	r30, X	
cp	r26, r20
cpc	r27, r21
brne	REL     	
lds	r24, XAE	
lds	r25, XAF	
adiw	r24, X	
sts	XAF, r25	
sts	XAE, r24	
ldi	r16, X	
ldi	r17, X	
rjmp	REL     	
cp	r20, r1
cpc	r21, r1
ldd	r24, Y+1	
ldd	r25, Y+2	
breq	REL     	
add	r20, r20
adc	r21, r21
add	r20, r24
adc	r21, r25
ld	r18, Z+
ld	r19, Z+
movw	r22, r30
movw	r30, r24
std	Z+1, r19	
st	Z, r18
movw	r30, r22
adiw	r24, X	
cp	r24, r20
cpc	r25, r21
brne	REL     	
sts	X, r10	
adiw	r26, X	
movw	r16, r26
ldi	r24, XA	
call	X	
mov	r24, r11
cpi	r24, X	
breq	REL      	
rjmp	REL    	
rjmp	REL    	

