//! Exclusive prefix sums on the CPU: the serial reference and a rayon-parallel version that
//! gives identical results (integer addition, wrapping on overflow like the GPU scan).

use rayon::prelude::*;

/// Replaces `data[i]` by the sum of `data[..i]` and returns the sum of all elements.
pub fn exclusive_scan(data: &mut [u32]) -> u32 {
    let mut acc = 0u32;
    for x in data.iter_mut() {
        let v = *x;
        *x = acc;
        acc = acc.wrapping_add(v);
    }
    acc
}

/// Elements per parallel chunk: large enough that the two passes stream memory.
const CHUNK: usize = 1 << 16;

/// The same result as [`exclusive_scan`], in two parallel passes (chunk totals, then
/// chunk-local scans offset by the scanned totals).
pub fn par_exclusive_scan(data: &mut [u32]) -> u32 {
    if data.len() <= CHUNK {
        return exclusive_scan(data);
    }
    let mut totals: Vec<u32> = data
        .par_chunks(CHUNK)
        .map(|c| c.iter().fold(0u32, |a, &x| a.wrapping_add(x)))
        .collect();
    let total = exclusive_scan(&mut totals);
    data.par_chunks_mut(CHUNK)
        .zip(totals.par_iter())
        .for_each(|(chunk, &offset)| {
            let mut acc = offset;
            for x in chunk.iter_mut() {
                let v = *x;
                *x = acc;
                acc = acc.wrapping_add(v);
            }
        });
    total
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::rng_u32;

    #[test]
    fn parallel_equals_serial() {
        for n in [0usize, 1, 7, CHUNK - 1, CHUNK, CHUNK + 1, 5 * CHUNK + 3] {
            let input: Vec<u32> = (0..n as u32).map(|i| rng_u32(3, 1, i)).collect();
            let (mut a, mut b) = (input.clone(), input);
            assert_eq!(exclusive_scan(&mut a), par_exclusive_scan(&mut b));
            assert_eq!(a, b, "length {n}");
        }
    }

    #[test]
    fn small_example() {
        let mut v = [3, 1, 4, 1, 5];
        assert_eq!(exclusive_scan(&mut v), 14);
        assert_eq!(v, [0, 3, 4, 8, 9]);
    }
}
