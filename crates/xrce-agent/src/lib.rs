//! DDS-XRCE agent library.
