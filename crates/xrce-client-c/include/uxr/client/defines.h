/* Helpers shared by the headers. */
#ifndef UXR_CLIENT_DEFINES_H_
#define UXR_CLIENT_DEFINES_H_
/* A compound literal in C, a plain braced initialiser in C++. */
#ifdef __cplusplus
#define COMPOUND_LITERAL(x) x
#else
#define COMPOUND_LITERAL(x) (x)
#endif
#endif /* UXR_CLIENT_DEFINES_H_ */
