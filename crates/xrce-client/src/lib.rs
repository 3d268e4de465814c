//! DDS-XRCE client.
#![cfg_attr(not(feature = "std"), no_std)]
