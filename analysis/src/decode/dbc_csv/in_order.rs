//! Pieces of a stream worked on by several threads and taken in the
//! stream's order: one thread fills them, one per core works on them, the
//! caller's takes each result as the one before it has been taken.
//!
//! Written here, not taken from a crate: the crates that map an iterator
//! in parallel in order (pariter, parseq) want `'static` work (the DBC is
//! borrowed here) and allocate every item, where a piece here is a few
//! hundred kilobytes of text and of rows that go round and are filled
//! again; and the first failure, wherever it is, must stop every thread.

use std::collections::BTreeMap;
use std::sync::mpsc::{channel, sync_channel};
use std::sync::{Arc, Mutex};

use acq_error::Result;

/// Runs `fill`, `work` and `take` on pieces: `fill` makes the next piece
/// (`false`: the stream has ended, the piece is not used), `work` does
/// the piece's work on one of `workers` threads, and `take` is given the
/// pieces in the order they were filled. `in_flight` pieces at most exist
/// (the memory held); each goes round again once taken. The first error,
/// of `take` or of `fill`, stops every thread: `take` is then given no
/// later piece, and the error is returned (`take`'s first: its piece came
/// before any `fill` failed to make). One worker: all on this thread.
pub(super) fn in_order<P: Default + Send>(
    workers: usize,
    in_flight: usize,
    mut fill: impl FnMut(&mut P) -> Result<bool> + Send,
    work: impl Fn(&mut P) + Sync,
    mut take: impl FnMut(&mut P) -> Result<()>,
) -> Result<()> {
    if workers <= 1 {
        let mut piece = P::default();
        while fill(&mut piece)? {
            work(&mut piece);
            take(&mut piece)?;
        }
        return Ok(());
    }
    let (give_back, returned) = channel::<P>();
    for _ in 0..in_flight.max(workers + 1) {
        // The receiver is alive: this thread holds it.
        let _ = give_back.send(P::default());
    }
    // Bounded by the pieces that exist; the channel only hands them over.
    let (filled, to_work) = sync_channel::<(u64, P)>(in_flight);
    // Shared by the workers alone: when the last has stopped (the taker
    // failed), a filler waiting to hand over a piece is told so.
    let to_work = Arc::new(Mutex::new(to_work));
    let (worked, to_take) = channel::<(u64, P)>();
    std::thread::scope(|scope| {
        let filling = scope.spawn(move || -> Result<()> {
            for number in 0.. {
                // Gone: the taker stopped.
                let Ok(mut piece) = returned.recv() else {
                    return Ok(());
                };
                if !fill(&mut piece)? || filled.send((number, piece)).is_err() {
                    return Ok(());
                }
            }
            Ok(())
        });
        for _ in 0..workers {
            let (to_work, worked, work) = (Arc::clone(&to_work), worked.clone(), &work);
            scope.spawn(move || loop {
                // A poisoned lock: another worker panicked, and the scope
                // passes its panic on.
                let next = match to_work.lock() {
                    Ok(receiver) => receiver.recv(),
                    Err(_) => return,
                };
                let Ok((number, mut piece)) = next else {
                    return;
                };
                work(&mut piece);
                if worked.send((number, piece)).is_err() {
                    return;
                }
            });
        }
        drop((worked, to_work));
        let taken = (|| -> Result<()> {
            let mut waiting = BTreeMap::new();
            let mut next = 0;
            for (number, piece) in to_take {
                waiting.insert(number, piece);
                while let Some(mut piece) = waiting.remove(&next) {
                    take(&mut piece)?;
                    next += 1;
                    // Gone: the filler ended.
                    let _ = give_back.send(piece);
                }
            }
            Ok(())
        })();
        // Stops the filler (no piece comes back), and with it the workers.
        drop(give_back);
        let filled = filling.join().expect("filling pieces does not panic");
        taken.and(filled)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use acq_error::AcqError;

    /// The numbers 0..count in pieces of `step`, each piece's work a sum
    /// that takes longer the smaller its start (so later pieces finish
    /// first), taken in order.
    fn sums(workers: usize, count: u64, step: u64, fail_at: Option<u64>) -> (Result<()>, Vec<u64>) {
        #[derive(Default)]
        struct Piece {
            start: u64,
            sum: u64,
        }
        let mut start = 0;
        let mut taken = Vec::new();
        let result = in_order(
            workers,
            4,
            |piece: &mut Piece| {
                if start >= count {
                    return Ok(false);
                }
                if fail_at == Some(start) {
                    return Err(AcqError::Malformed(format!("cannot read at {start}")));
                }
                piece.start = start;
                start += step;
                Ok(true)
            },
            |piece| {
                let spin = (count - piece.start) * 1000;
                piece.sum = (0..spin).fold(piece.start, |a, b| std::hint::black_box(a ^ b));
                piece.sum = (piece.start..(piece.start + step).min(count)).sum();
            },
            |piece| {
                taken.push(piece.sum);
                Ok(())
            },
        );
        (result, taken)
    }

    #[test]
    fn pieces_are_taken_in_order_whatever_the_workers() {
        let expected: Vec<u64> = (0..100u64)
            .step_by(7)
            .map(|s| (s..(s + 7).min(100)).sum())
            .collect();
        for workers in [1, 2, 3, 8] {
            let (result, taken) = sums(workers, 100, 7, None);
            assert!(result.is_ok());
            assert_eq!(taken, expected, "{workers} workers");
        }
    }

    #[test]
    fn a_failure_to_fill_stops_after_the_pieces_before_it() {
        for workers in [1, 2, 4] {
            let (result, taken) = sums(workers, 100, 10, Some(50));
            assert!(result
                .unwrap_err()
                .to_string()
                .contains("cannot read at 50"));
            assert_eq!(taken.len(), 5, "{workers} workers");
        }
    }

    #[test]
    fn a_failure_to_take_stops_every_thread() {
        for workers in [1, 2, 4] {
            let mut taken = 0;
            let mut filled = 0;
            let result = in_order(
                workers,
                3,
                |_: &mut u64| {
                    filled += 1;
                    Ok(filled < 10_000)
                },
                |_| {},
                |_| {
                    taken += 1;
                    if taken == 5 {
                        return Err(AcqError::Malformed("the disk is full".into()));
                    }
                    Ok(())
                },
            );
            assert!(result.unwrap_err().to_string().contains("the disk is full"));
            assert_eq!(taken, 5);
            // Stopped within the pieces in flight, not at the stream's end.
            assert!(filled < 20, "{workers} workers filled {filled}");
        }
    }
}
