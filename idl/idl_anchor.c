/* Anchor translation unit: the generated swarmloc.c is added by idlc_generate. */
