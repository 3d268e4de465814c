/* Symbol visibility of the Micro-CDR functions: a static library, nothing to export or import. */
#ifndef UCDR_VISIBILITY_H_
#define UCDR_VISIBILITY_H_
#define UCDRDLLAPI
#endif /* UCDR_VISIBILITY_H_ */
