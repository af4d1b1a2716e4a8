//! A fingerprint of a scan's ranges, to check that it crossed the transport bit for bit.

/// FNV-1a (64 bit) over the little-endian bit patterns of `ranges_m`: a cheap fingerprint
/// to check that a scan crossed the transport bit for bit (NaN and infinities included).
pub fn ranges_checksum(ranges_m: &[f32]) -> u64 {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for r in ranges_m {
        for byte in r.to_bits().to_le_bytes() {
            hash ^= u64::from(byte);
            hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    hash
}
