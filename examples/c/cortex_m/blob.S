/* The mesh blob (`tetradrill export --firmware`) in flash, read in place by
 * td_world_init_blob: BLOB_FILE names it at build time (make BLOB=FILE). */
    .section .rodata.mesh_blob, "a"
    .balign 4
    .global mesh_blob
mesh_blob:
    .incbin BLOB_FILE
    .global mesh_blob_end
mesh_blob_end:
