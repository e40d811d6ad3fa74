//! The CSV readers' limits: an IMU log is refused at its first line beyond the rows the caller
//! accepts, having read and kept no more than them (an endless input included); an estimates
//! file's times must increase strictly, as an IMU log's do.

use liebayes_filters::attitude::{DataError, read_estimates_csv, read_imu_csv_at_most};
use std::io::{BufReader, Read};

const HEADER_6D: &str = "t,gx,gy,gz,ax,ay,az\n";

/// `n` samples of a 6D log at 100 Hz.
fn log_6d(n: usize) -> String {
    let samples = (0..n).map(|k| format!("{},0,0,0,0,0,9.8\n", k as f64 * 0.01));
    std::iter::once(HEADER_6D.to_owned())
        .chain(samples)
        .collect()
}

/// The line, limit and what of a [`DataError::TooManyRows`], its message checked to name the file
/// and the line.
fn too_many_rows(result: Result<impl std::fmt::Debug, DataError>) -> (usize, usize, &'static str) {
    match result {
        Err(error @ DataError::TooManyRows { .. }) => {
            let DataError::TooManyRows {
                ref origin,
                line,
                limit,
                what,
            } = error
            else {
                unreachable!()
            };
            let message = error.to_string();
            assert!(
                message.starts_with(&format!("{origin}: line {line}: more than {limit} {what}")),
                "{message}"
            );
            (line, limit, what)
        }
        other => panic!("expected TooManyRows, got {other:?}"),
    }
}

#[test]
fn an_imu_log_beyond_the_limit_is_refused_at_its_first_line_beyond() {
    let log = read_imu_csv_at_most(log_6d(3).as_bytes(), "three.csv", 3).expect("3 of 3 samples");
    assert_eq!(log.len(), 3);
    // Sample 4 is on line 5 (the header is line 1).
    assert_eq!(
        too_many_rows(read_imu_csv_at_most(log_6d(4).as_bytes(), "four.csv", 3)),
        (5, 3, "samples")
    );
    // The count is checked before the row is parsed: a malformed row beyond the limit is refused
    // for the count.
    let text = format!("{}x\n", log_6d(3));
    assert_eq!(
        too_many_rows(read_imu_csv_at_most(text.as_bytes(), "x.csv", 3)),
        (5, 3, "samples")
    );
    // 9D, and a limit above the library's is the library's.
    let nine =
        "t,gx,gy,gz,ax,ay,az,mx,my,mz\n0,0,0,0,0,0,9.8,0,20,-40\n0.5,0,0,0,0,0,9.8,0,20,-40\n";
    assert_eq!(
        too_many_rows(read_imu_csv_at_most(nine.as_bytes(), "nine.csv", 1)),
        (3, 1, "samples")
    );
    let log = read_imu_csv_at_most(nine.as_bytes(), "nine.csv", usize::MAX).expect("reads");
    assert!(log.magnetometer().is_some() && log.rate() == 2.0);
}

/// Serves the same sample line forever, counting the bytes served.
struct Endless {
    served: usize,
}

impl Read for Endless {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        const LINE: &[u8] = b"0,0,0,0,0,0,9.8\n";
        for (i, byte) in buf.iter_mut().enumerate() {
            *byte = LINE[(self.served + i) % LINE.len()];
        }
        self.served += buf.len();
        Ok(buf.len())
    }
}

/// A file of 2^28 rows held 21 GB before the reader refused it; an endless one is refused at the
/// line after the limit, having read no further than that line and the reader's buffer.
#[test]
fn an_endless_imu_log_is_refused_having_read_only_the_limit() {
    const LIMIT: usize = 100_000;
    let mut endless = Endless { served: 0 };
    let reader = BufReader::new(HEADER_6D.as_bytes().chain(&mut endless));
    assert_eq!(
        too_many_rows(read_imu_csv_at_most(reader, "endless.csv", LIMIT)),
        (LIMIT + 2, LIMIT, "samples")
    );
    let line = "0,0,0,0,0,0,9.8\n".len();
    assert!(
        endless.served <= (LIMIT + 1) * line + 8192,
        "{} bytes read",
        endless.served
    );
}

/// Times that go back or repeat were read as they came; they are refused now, naming the line and
/// the time column, as the IMU reader names a time off its rate.
#[test]
fn estimates_times_must_increase_strictly() {
    let cases: [(&str, usize); 3] = [
        // Back in time on line 3 (and repeated on line 4).
        ("t,w,x,y,z\n1,1,0,0,0\n0,1,0,0,0\n0,1,0,0,0\n", 3),
        ("t,w,x,y,z\n0,1,0,0,0\n0.5,1,0,0,0\n0.5,1,0,0,0\n", 4),
        (
            "t,w,x,y,z\n0,1,0,0,0\n1,1,0,0,0\n2,1,0,0,0\n-1,1,0,0,0\n",
            5,
        ),
    ];
    for (text, line) in cases {
        let error = read_estimates_csv(text.as_bytes(), "times.csv").expect_err(text);
        assert!(
            matches!(error, DataError::Csv { line: l, column: 1, .. } if l == line),
            "{text:?}: {error:?}"
        );
        let message = error.to_string();
        assert!(
            message.starts_with(&format!("times.csv: line {line}, column 1: time "))
                && message.contains("expected"),
            "{message}"
        );
    }
    let increasing = "t,w,x,y,z\n-1,1,0,0,0\n0,1,0,0,0\n1e-9,1,0,0,0\n";
    let read = read_estimates_csv(increasing.as_bytes(), "ok.csv").expect("reads");
    assert_eq!(read.times, [-1.0, 0.0, 1e-9]);
}

/// A header after a UTF-8 byte-order mark (as spreadsheet programs write it) is read as the
/// header; times whose rate is out of range are refused on line 2 with the rate and the range,
/// and times whose span overflows are called that, not "not increasing" (an audit found the first
/// refused as a wrong header, the second reported as the variable `sampling_rate` at row 0, and
/// the third as times that do not increase).
#[test]
fn a_byte_order_mark_is_skipped_and_rates_are_checked_where_read() {
    let read = |text: &str| read_imu_csv_at_most(text.as_bytes(), "log.csv", 100);
    let marked = format!("\u{feff}{}", log_6d(3));
    assert_eq!(read(&marked).unwrap().len(), 3);
    let estimates = "\u{feff}t,w,x,y,z\n0,1,0,0,0\n1,1,0,0,0\n";
    assert_eq!(
        read_estimates_csv(estimates.as_bytes(), "e.csv")
            .unwrap()
            .times
            .len(),
        2
    );
    for (times, rate) in [
        ([0.0, 5e-324], "inf Hz"),
        ([0.0, 1e4], "1e-4 Hz"),
        ([-1.7e308, 1.7e308], "0e0 Hz"),
    ] {
        let text = format!(
            "{HEADER_6D}{},0,0,0,0,0,9.8\n{},0,0,0,0,0,9.8\n",
            times[0], times[1]
        );
        let message = read(&text).unwrap_err().to_string();
        assert!(
            message.starts_with("log.csv: line 2, column 1:")
                && message.contains(rate)
                && message.contains("expected a rate in [1e-3, 1e6] Hz"),
            "{message}"
        );
    }
}
