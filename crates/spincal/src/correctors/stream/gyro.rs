//! A gyro file merged on time into `correct`'s pipeline (the rule of
//! [`attach_gyro_file`](crate::input::gyro_file::attach_gyro_file), row by row): delimited text is
//! read row by row and interpolated at each input row's time holding only the two gyro samples
//! around it ([`Bracket`]); any other format, or reading options that need the whole file, is
//! read whole. A file without a time column pairs its samples with the input's, one for one.
//! Rows outside the gyro's span or in its gaps keep their corrected accelerometer, are marked
//! `no-gyro: …` and counted; fewer than half the rows covered stops the correction naming both
//! spans.

use std::collections::VecDeque;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;

use super::CorrectError;
use crate::input::formats::{whitespace_map, ReadOptions};
use crate::input::gyro_file::{
    beside_note, gyro_read_options, read_gyro_file, GyroFileError, GYRO_COUNTS_RADPS, GYRO_GAP_INTERVALS,
};
use crate::input::recording::{
    gyro_only_map, sample_interval, Bracket, ColumnPlan, RecordingError, Uncovered,
};
use crate::input::table::{display_name, Location, Record, RowReader};

/// Gyro rows read ahead to learn its time unit and its sampling interval.
const GYRO_LOOK_AHEAD_ROWS: usize = 256;

/// Where the gyro's samples come from.
enum Samples {
    /// Delimited text, row by row.
    Rows(Box<GyroRows>),
    /// Read whole (`next`: the next sample to give).
    Whole {
        time_s: Vec<f64>,
        values: [Vec<f64>; 3],
        next: usize,
    },
}

/// A delimited gyro file read row by row.
struct GyroRows {
    reader: RowReader<Box<dyn BufRead>>,
    time_column: usize,
    value_columns: [usize; 3],
    time_to_s: f64,
    to_radps: f64,
    ahead: VecDeque<(f64, [f64; 3])>,
    values: Vec<f64>,
    previous: Option<f64>,
    /// Rows without every value used, or that could not be read: left out.
    left_out: usize,
}

impl GyroRows {
    fn open(path: &Path, options: &ReadOptions) -> Result<(GyroRows, Vec<String>, bool), CorrectError> {
        let name = display_name(path);
        let opened = crate::input::limits::check_streamable(path).and_then(|()| File::open(path));
        let file = opened.map_err(|source| CorrectError::Open {
            file: name.clone(),
            source,
        })?;
        let reader: Box<dyn BufRead> = Box::new(BufReader::new(file));
        let mut reader = RowReader::new(reader, &name, &options.columns.table)?;
        let width = reader.width();
        let map = whitespace_map(options.columns.clone(), reader.header.is_empty(), width);
        // A header of time and gyro columns alone: by the rule a file read whole follows.
        let map = gyro_only_map(&reader.header, map);
        let mut plan = ColumnPlan::new(&reader.header, width, &name, &map)?;
        reader.choose_columns(plan.used_columns());
        // imu_tk's `t gx gy gz` is read as time and three values; a file with gyro columns by them.
        let (value_columns, to_radps) = match plan.gyro_columns() {
            Some(columns) => (columns, plan.gyro_to_radps().unwrap_or(1.0)),
            None => (plan.accel_columns(), map.gyro_unit.map_or(1.0, |u| u.to_si())),
        };
        let to_radps = to_radps * options.gyro_scale.unwrap_or(1.0);
        let mut rows = GyroRows {
            reader,
            time_column: plan.time_column(),
            value_columns,
            time_to_s: 1.0,
            to_radps,
            ahead: VecDeque::new(),
            values: Vec::with_capacity(width),
            previous: None,
            left_out: 0,
        };
        // The first rows settle the time column's unit, as a file read whole does.
        let mut raw = Vec::new();
        while raw.len() < GYRO_LOOK_AHEAD_ROWS {
            let Some((line, t, v)) = rows.next_raw()? else {
                break;
            };
            raw.push((line, t, v));
        }
        let k = plan.time_to_s();
        let mut times: Vec<f64> = raw.iter().map(|(_, t, _)| t * k).collect();
        let notes = plan
            .settle_time(&mut times, &name, &[])
            .map_err(RecordingError::from)?;
        rows.time_to_s = plan.time_to_s();
        for (line, t, v) in raw {
            let sample = rows.checked(line, t, v)?;
            rows.ahead.push_back(sample);
        }
        let mean_beyond = (0..3).any(|a| {
            let n = rows.ahead.len().max(1) as f64;
            (rows.ahead.iter().map(|(_, v)| v[a]).sum::<f64>() / n).abs() > GYRO_COUNTS_RADPS
        });
        Ok((rows, notes, mean_beyond && options.gyro_scale.is_none()))
    }

    /// The next row's line, raw time and values in rad/s (rows without every value left out).
    fn next_raw(&mut self) -> Result<Option<(usize, f64, [f64; 3])>, CorrectError> {
        while let Some(record) = self.reader.next_record(&mut self.values)? {
            let Record::Parsed { line } = record else {
                self.left_out += 1;
                continue;
            };
            let v = self.value_columns.map(|c| self.values[c] * self.to_radps);
            let t = self.values[self.time_column];
            if t.is_finite() && v.iter().all(|x| x.is_finite()) {
                return Ok(Some((line, t, v)));
            }
            self.left_out += 1;
        }
        Ok(None)
    }

    /// A row's time in s, checked to go forward.
    fn checked(&mut self, line: usize, raw_t: f64, v: [f64; 3]) -> Result<(f64, [f64; 3]), CorrectError> {
        let t = raw_t * self.time_to_s;
        if let Some(previous) = self.previous.filter(|p| t < *p) {
            return Err(RecordingError::TimeNotIncreasing {
                at: Location {
                    file: self.reader.file().to_string(),
                    line,
                    column: Some(self.time_column + 1),
                    column_name: None,
                },
                previous,
                current: t,
            }
            .into());
        }
        self.previous = Some(t);
        Ok((t, v))
    }

    fn next(&mut self) -> Result<Option<(f64, [f64; 3])>, CorrectError> {
        if let Some(sample) = self.ahead.pop_front() {
            return Ok(Some(sample));
        }
        match self.next_raw()? {
            Some((line, t, v)) => self.checked(line, t, v).map(Some),
            None => Ok(None),
        }
    }
}

impl Samples {
    fn next(&mut self) -> Result<Option<(f64, [f64; 3])>, CorrectError> {
        match self {
            Samples::Rows(rows) => rows.next(),
            Samples::Whole { time_s, values, next } => {
                let sample = time_s
                    .get(*next)
                    .map(|&t| (t, std::array::from_fn(|a| values[a][*next])));
                *next += 1;
                Ok(sample)
            }
        }
    }
}

/// The gyro file of one correction and what it has covered so far.
pub(super) struct GyroMerge {
    pub(super) file: String,
    samples: Samples,
    bracket: Bracket,
    /// The file has a time column (else it pairs sample for sample).
    pub(super) timed: bool,
    /// Its values are raw counts.
    pub(super) counts: bool,
    interval_s: f64,
    /// What was decided about its time column.
    notes: Vec<String>,
    rows: usize,
    covered: usize,
    given: usize,
    gyro_first_s: Option<f64>,
    gyro_last_s: f64,
    rows_first_s: Option<f64>,
    rows_last_s: f64,
}

impl GyroMerge {
    /// Opens the gyro file at `path` with the recording's reading `options`.
    pub(super) fn open(path: &Path, options: &ReadOptions) -> Result<GyroMerge, CorrectError> {
        let options = gyro_read_options(options);
        let file = display_name(path);
        let (samples, timed, counts, interval_s, notes) = if super::reads_whole_file(path, &options)? {
            let gyro = read_gyro_file(path, &options).map_err(|e| CorrectError::Gyro(Box::new(e)))?;
            let interval = sample_interval(&gyro.time_s);
            let samples = Samples::Whole {
                time_s: gyro.time_s,
                values: gyro.values,
                next: 0,
            };
            (samples, gyro.timed, gyro.counts, interval, Vec::new())
        } else {
            let (rows, notes, counts) = GyroRows::open(path, &options)?;
            let times: Vec<f64> = rows.ahead.iter().map(|(t, _)| *t).collect();
            (
                Samples::Rows(Box::new(rows)),
                true,
                counts,
                sample_interval(&times),
                notes,
            )
        };
        Ok(GyroMerge {
            file,
            samples,
            // A gyro sampled beside the rows: sample for sample, the rule of a file read whole.
            bracket: Bracket::new(GYRO_GAP_INTERVALS * interval_s).beside(0.5 * interval_s),
            timed,
            counts,
            interval_s,
            notes,
            rows: 0,
            covered: 0,
            given: 0,
            gyro_first_s: None,
            gyro_last_s: f64::NAN,
            rows_first_s: None,
            rows_last_s: f64::NAN,
        })
    }

    /// The gyro, rad/s (or counts), at the next input row, at `t_s`: interpolated, or the next
    /// sample of a file without time; why not when the row is outside its span or in a gap.
    pub(super) fn at(&mut self, t_s: f64) -> Result<Result<[f64; 3], Uncovered>, CorrectError> {
        self.rows += 1;
        self.rows_first_s.get_or_insert(t_s);
        self.rows_last_s = t_s;
        let (samples, first, last, given) = (
            &mut self.samples,
            &mut self.gyro_first_s,
            &mut self.gyro_last_s,
            &mut self.given,
        );
        let mut pull = || -> Result<_, CorrectError> {
            let sample = samples.next()?;
            if let Some((t, _)) = sample {
                first.get_or_insert(t);
                *last = t;
                *given += 1;
            }
            Ok(sample)
        };
        let value = if self.timed {
            self.bracket.at(t_s, pull)?
        } else {
            pull()?.map(|(_, v)| v).ok_or(Uncovered::After { last_s: *last })
        };
        self.covered += usize::from(value.is_ok());
        Ok(value)
    }

    /// After the last row: the gyro read to its end (its span and length), the overlap checked
    /// (under half the rows covered: refused naming both spans; without a time column: as many
    /// samples as rows), and the notes for the summary.
    pub(super) fn finish(mut self) -> Result<Vec<String>, CorrectError> {
        while let Some((t, _)) = self.samples.next()? {
            self.gyro_first_s.get_or_insert(t);
            self.gyro_last_s = t;
            self.given += 1;
        }
        let gyro_error = |e| CorrectError::Gyro(Box::new(e));
        if !self.timed && self.given != self.rows {
            return Err(gyro_error(GyroFileError::Length {
                file: self.file,
                found: self.given,
                expected: self.rows,
            }));
        }
        if self.timed && (2 * self.covered < self.rows || self.covered < 2) {
            return Err(gyro_error(GyroFileError::NoOverlap {
                file: self.file,
                covered: self.covered,
                samples: self.rows,
                gyro_from_s: self.gyro_first_s.unwrap_or(f64::NAN),
                gyro_to_s: self.gyro_last_s,
                from_s: self.rows_first_s.unwrap_or(f64::NAN),
                to_s: self.rows_last_s,
            }));
        }
        let mut notes: Vec<String> = (self.notes.iter())
            .map(|n| format!("the gyroscope of {}: {n}", self.file))
            .collect();
        if let Samples::Rows(rows) = &self.samples {
            if rows.left_out > 0 {
                notes.push(format!(
                    "the gyroscope of {}: {} rows without every value left out",
                    self.file, rows.left_out
                ));
            }
        }
        let paired = self.bracket.paired();
        notes.push(if self.timed && paired == self.rows {
            format!(
                "the gyroscope of {} ({} samples) sampled beside the input's {} rows: taken sample for sample",
                self.file, self.given, self.rows
            )
        } else if self.timed {
            format!(
                "the gyroscope of {} ({} samples, {:.1} Hz) interpolated linearly onto the input's {} rows{}; {} rows outside its span or in its gaps (> {GYRO_GAP_INTERVALS} intervals) written without it (status no-gyro)",
                self.file,
                self.given,
                1.0 / self.interval_s,
                self.rows,
                beside_note(paired),
                self.rows - self.covered
            )
        } else {
            format!(
                "the gyroscope of {} has no time column: its {} samples taken sample for sample",
                self.file, self.given
            )
        });
        Ok(notes)
    }
}

/// The status of a row whose accelerometer was corrected but which has no gyro: `no-gyro`, the
/// line and why, after the accelerometer's own status when it is not `ok`.
pub(super) fn without_gyro(status: &str, line: usize, why: Uncovered) -> String {
    let reason = format!("no-gyro: line {line}, {why}");
    if status == "ok" {
        reason
    } else {
        format!("{status}; {reason}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::formats::{Format, Loaded};
    use crate::input::gyro_file::attach_gyro_file;
    use crate::input::recording::{interpolate_onto, Recording};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    fn sd(v: &[f64]) -> f64 {
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
    }

    /// A gyro logged beside a 100 Hz accelerometer (each time within a fifth of an interval of
    /// the accelerometer's), white noise σ = 0.01 rad/s, as `t,gx,gy,gz`. Read whole (what
    /// calibrate, fit, allan and static take) and streamed (what correct takes), every row gets
    /// the file's own sample, bit for bit, so the merged gyro's white noise is the file's (within
    /// 4 %, 3.5 standard errors of a standard deviation over 4000 samples); interpolated between
    /// samples (weights within a fifth of an interval of 0 or 1) it reads about 0.91 σ.
    #[test]
    fn a_gyro_sampled_beside_the_rows_is_taken_sample_for_sample_whole_and_streamed() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let n = 4000;
        let sigma = 0.01;
        let accel_t: Vec<f64> = (0..n).map(|i| i as f64 / 100.0).collect();
        let gyro_t: Vec<f64> = accel_t.iter().map(|t| t + rng.gen_range(-0.002..0.002)).collect();
        let values: [Vec<f64>; 3] = std::array::from_fn(|a| {
            (0..n)
                .map(|_| {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    0.1 * a as f64 + sigma * z
                })
                .collect()
        });
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("gyro.csv");
        let mut text = String::from("t,gx,gy,gz\n");
        for i in 0..n {
            text += &format!(
                "{},{},{},{}\n",
                gyro_t[i], values[0][i], values[1][i], values[2][i]
            );
        }
        std::fs::write(&path, text).unwrap();
        let recording = Recording {
            time_s: accel_t.clone(),
            accel_mps2: [vec![0.0; n], vec![0.0; n], vec![9.81; n]],
            gyro_radps: None,
            temperature_c: None,
            source: Default::default(),
        };
        let mut loaded = Loaded::new(recording, Format::Csv, false);
        let note = attach_gyro_file(&mut loaded, &path, &ReadOptions::default()).unwrap();
        assert_eq!(note, None);
        let whole = loaded.recording.gyro_radps.unwrap();
        assert_eq!(whole, values, "read whole: the file's own samples");
        let mut merge = GyroMerge::open(&path, &ReadOptions::default()).unwrap();
        assert!(matches!(merge.samples, Samples::Rows(_)), "streamed row by row");
        for (i, &t) in accel_t.iter().enumerate() {
            let v = merge.at(t).unwrap().unwrap();
            assert_eq!(v, [whole[0][i], whole[1][i], whole[2][i]], "row {i}");
        }
        let notes = merge.finish().unwrap();
        assert!(
            notes.iter().any(|n| n.contains("taken sample for sample")),
            "{notes:?}"
        );
        let ratio = sd(&whole[0]) / sigma;
        assert!((ratio - 1.0).abs() < 0.04, "white noise {ratio} σ");
        // The check can fail: interpolated onto the rows, the same file's noise is lowered.
        let (_, smoothed) = interpolate_onto(&accel_t[1..n - 1], &gyro_t, &values, 0.03);
        let smoothed_ratio = sd(&smoothed[0]) / sigma;
        assert!(smoothed_ratio < 0.96, "interpolated: {smoothed_ratio} σ");
    }
}
