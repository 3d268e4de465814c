/* Symbol visibility of the client library's functions: a static library, nothing to export or import. */
#ifndef UXR_CLIENT_VISIBILITY_H_
#define UXR_CLIENT_VISIBILITY_H_
#define UXRDLLAPI
#endif /* UXR_CLIENT_VISIBILITY_H_ */
