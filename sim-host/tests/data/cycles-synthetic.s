@ Synthetic Cortex-M4 program for sim-host/tests/cycles.rs (cycle-model cross-check).
@ Rebuild: llvm-mc --triple=thumbv7em-none-eabihf -mattr=+vfp4d16sp --filetype=obj -o s.o cycles-synthetic.s && llvm-objcopy -O binary s.o s.bin
    .syntax unified
    .thumb
    .text
    .word 0x20001000
    .word reset + 1
reset:
    ldr r0, =0xE000ED88
    ldr r1, =0x00F00000
    str r1, [r0]
    dsb
    isb
    bl func
    movs r0, #0x18
    ldr r1, =0x20026
    bkpt #0xab
1:  b 1b
    .ltorg
    .balign 16
func:
    push {r4, lr}
    movs r0, #10
    mov r1, sp
    ldr r2, [r1]
loop:
    ldr r2, [sp]
    ldr r3, [sp, #4]
    subs r0, #1
    bne loop
    vdiv.f32 s0, s0, s1
    vadd.f32 s2, s2, s3
    add.w r4, r4, #1
    add.w r4, r4, #1
    add.w r4, r4, #1
    add.w r4, r4, #1
    add.w r4, r4, #1
    add.w r4, r4, #1
    add.w r4, r4, #1
    add.w r4, r4, #1
    pop {r4, pc}
