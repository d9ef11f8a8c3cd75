/* The frame the Rust firmware embeds (made by `cargo xtask frames`), in DMA order:
 * loop -> TX slot -> RX -> sample, [I, Q] int16 little-endian. DBE_FRAME is its path. */
    .section .rodata
    .balign 4
    .global dbe_frame
dbe_frame:
    .incbin DBE_FRAME
    .global dbe_frame_end
dbe_frame_end:
