//! `fluid-node --ranks-support`: whether this binary can run as several MPI ranks, answered
//! before anything else. The coupler asks before a run on ranks makes its run directory: a node
//! built without MPI found out only once the launcher had started it, after the run directory
//! was made (and after a `--resume` had cut the run back to its checkpoint).

/// The flag, alone on the command line: the node prints [`answer`] and exits.
pub const FLAG: &str = "--ranks-support";

/// The answer's first words, so that another program's output is not taken for one.
const PREFIX: &str = "MPI ranks: ";

/// What to do about a node built without MPI, in its own refusal and in the coupler's.
pub const WITHOUT_MPI_FIX: &str = "rebuild with `cargo build --release --features fluid-node/mpi` \
     (Debian packages libopenmpi-dev openmpi-bin libclang-dev), or run one fluid rank";

/// This binary's answer: `MPI ranks: yes`, or `MPI ranks: no: ` and why, with the fix.
pub fn answer() -> String {
    if cfg!(feature = "mpi") {
        format!("{PREFIX}yes")
    } else {
        format!("{PREFIX}no: built without MPI. Fix: {WITHOUT_MPI_FIX}")
    }
}

/// What a node printed for [`FLAG`]: `Some(Ok)` it can, `Some(Err(why))` it cannot, `None` no
/// answer (a node of one's own that does not know the flag).
pub fn read(said: &str) -> Option<Result<(), String>> {
    let rest = said.lines().next()?.strip_prefix(PREFIX)?;
    match rest.strip_prefix("no: ") {
        Some(why) => Some(Err(why.to_string())),
        None if rest == "yes" => Some(Ok(())),
        None => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_answer_reads_back_and_other_output_is_no_answer() {
        assert_eq!(read(&answer()).unwrap().is_ok(), cfg!(feature = "mpi"));
        let no = read("MPI ranks: no: built without MPI. Fix: x\n").unwrap();
        assert_eq!(no.unwrap_err(), "built without MPI. Fix: x");
        assert!(read("error: unexpected argument '--ranks-support' found").is_none());
        assert!(read("").is_none());
    }
}
