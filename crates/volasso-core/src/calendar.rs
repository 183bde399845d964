//! Dates from seconds since 1970 (UTC), for file names, the gallery's cards and the dates DICOM
//! objects carry: one conversion, with no time-zone database.
//!
//! Never: reads the clock; callers pass the time.

/// `unix` seconds as UTC in ISO 8601 to the second, e.g. `2026-12-06T11:02:03Z`.
pub fn iso_utc(unix: u64) -> String {
    let [year, month, day] = civil_from_days((unix / 86_400) as i64);
    let seconds = unix % 86_400;
    format!("{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z", seconds / 3600, seconds / 60 % 60, seconds % 60)
}

/// Days from 1970-01-01 to the day `year`-`month`-`day` (proleptic Gregorian; H. Hinnant's
/// `days_from_civil`, the inverse of [`civil_from_days`]).
pub fn days_from_civil(year: i64, month: i64, day: i64) -> i64 {
    let year = if month <= 2 { year - 1 } else { year };
    let era = year.div_euclid(400);
    let year_of_era = year.rem_euclid(400);
    let shifted_month = if month > 2 { month - 3 } else { month + 9 };
    let day_of_year = (153 * shifted_month + 2) / 5 + day - 1;
    let day_of_era = year_of_era * 365 + year_of_era / 4 - year_of_era / 100 + day_of_year;
    era * 146_097 + day_of_era - 719_468
}

/// Year, month, day of the day `days` after 1970-01-01 (proleptic Gregorian; H. Hinnant's
/// `civil_from_days`).
pub fn civil_from_days(days: i64) -> [i64; 3] {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let day_of_era = z.rem_euclid(146_097);
    let year_of_era = (day_of_era - day_of_era / 1460 + day_of_era / 36_524 - day_of_era / 146_096) / 365;
    let day_of_year = day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);
    let shifted_month = (5 * day_of_year + 2) / 153;
    let day = day_of_year - (153 * shifted_month + 2) / 5 + 1;
    let month = if shifted_month < 10 { shifted_month + 3 } else { shifted_month - 9 };
    [year_of_era + era * 400 + i64::from(month <= 2), month, day]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iso_utc_counts_days_hours_minutes_and_seconds() {
        assert_eq!(iso_utc(0), "1970-01-01T00:00:00Z");
        assert_eq!(iso_utc(1_796_554_923), "2026-12-06T11:02:03Z");
        assert_eq!(iso_utc(951_868_799), "2000-02-29T23:59:59Z");
    }

    #[test]
    fn days_from_civil_undoes_civil_from_days() {
        for days in (-800_000..800_000).step_by(997) {
            let [year, month, day] = civil_from_days(days);
            assert_eq!(days_from_civil(year, month, day), days);
        }
        assert_eq!(days_from_civil(2026, 12, 6), 20_793);
    }
}
