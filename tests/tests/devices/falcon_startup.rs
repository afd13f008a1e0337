//! What `tetradrill run --device falcon` says when the Falcon does not start: one line that
//! names the flag and what to do, for each way start-up fails.

use std::path::Path;

use tetradrill::commands::run::falcon_start_error;
use tetradrill_device::DeviceError;

#[test]
fn each_start_up_failure_is_one_line_saying_what_to_do() {
    let file = Path::new("novint.bin");
    let cases: [(DeviceError, Option<&Path>, &[&str]); 5] = [
        (
            DeviceError::FirmwareNotRunning,
            None,
            &[
                "--device falcon",
                "no firmware answers",
                "--falcon-firmware FILE",
            ],
        ),
        (
            DeviceError::FirmwareNotRunning,
            Some(file),
            &["no firmware answers", "novint.bin", "unplug"],
        ),
        (
            DeviceError::FirmwareFile,
            Some(file),
            &["firmware file", "novint.bin", "--falcon-firmware"],
        ),
        (
            DeviceError::FirmwareHandshake { step: 5 },
            Some(file),
            &["step 5", "unplug"],
        ),
        (
            DeviceError::FirmwareMismatch { offset: 256 },
            Some(file),
            &["256", "unplug"],
        ),
    ];
    for (e, firmware, needles) in cases {
        let line = falcon_start_error(e, firmware);
        assert_eq!(line.lines().count(), 1, "{line}");
        for n in needles {
            assert!(line.contains(n), "{line:?} lacks {n:?}");
        }
    }
}
