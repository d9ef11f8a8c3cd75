/* Output and exit of the C firmware through semihosting (startup.c). */
#ifndef SEMIHOST_H
#define SEMIHOST_H
void sh_write0(const char *s);
void sh_exit(int status) __attribute__((noreturn));
#endif
