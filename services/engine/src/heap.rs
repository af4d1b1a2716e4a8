//! Heap accounting for `Mapper::heap_bytes` (what `/metrics` reports of a session's
//! memory): the bytes a container holds, from its capacity. An estimate: it counts what
//! the vector reserved, not the allocator's overhead.

/// Bytes a vector's buffer holds: `capacity · size_of::<T>()` (the elements' own heap, if
/// any, is the caller's to add). O(1).
pub(crate) fn vec_bytes<T>(v: &Vec<T>) -> usize {
    v.capacity() * std::mem::size_of::<T>()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_buffer_counts_its_capacity_not_its_length() {
        let mut v: Vec<u32> = Vec::with_capacity(10);
        v.push(1);
        assert_eq!(vec_bytes(&v), 40);
        assert_eq!(vec_bytes(&Vec::<u64>::new()), 0);
    }
}
