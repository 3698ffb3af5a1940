//! The one CRC of the project: CRC-32/ISO-HDLC, used for link frames, parameter-set
//! checksums and the message-schema hash.

pub const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);
