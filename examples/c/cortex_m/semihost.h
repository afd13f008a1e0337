/* Output and exit through semihosting (startup.c). */
#ifndef TETRADRILL_EXAMPLE_SEMIHOST_H
#define TETRADRILL_EXAMPLE_SEMIHOST_H

/* Writes a NUL-terminated string to the host's console. */
void sh_puts(const char *s);

/* Ends the program: QEMU exits with status 0 when `ok`, 1 otherwise. */
void sh_exit(int ok) __attribute__((noreturn));

#endif
