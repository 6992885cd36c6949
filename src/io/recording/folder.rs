//! A rosbag2 bag named as ROS 2 users name it: its folder, `metadata.yaml` beside the storage
//! file (`.mcap` or `.db3`). Only names and the metadata's text come in, so the CLI and the
//! page resolve a folder the same way.

use serde::Deserialize;

/// Extensions of a recording's storage file, as [`Recording::open`](super::Recording::open)
/// reads them.
const STORAGE: [&str; 3] = ["mcap", "db3", "bag"];

#[derive(Deserialize)]
struct Metadata {
    rosbag2_bagfile_information: Information,
}

#[derive(Deserialize)]
struct Information {
    #[serde(default)]
    relative_file_paths: Vec<String>,
}

/// The name of the one storage file in the bag folder `folder` (for messages) whose entries are
/// `names`, following `metadata.yaml` (its text in `metadata`) when there is one. A split bag
/// (several storage files) is refused with what to do: one [`Recording`](super::Recording)
/// reads one file.
pub fn storage_file(
    folder: &str,
    names: &[String],
    metadata: Option<&str>,
) -> Result<String, String> {
    let listed: Vec<String> = match metadata {
        Some(text) => {
            let meta: Metadata = serde_norway::from_str(text)
                .map_err(|e| format!("{folder}/metadata.yaml: not rosbag2 metadata ({e})"))?;
            let files = meta.rosbag2_bagfile_information.relative_file_paths;
            if let Some(missing) = files.iter().find(|f| !names.contains(f)) {
                return Err(format!(
                    "{folder}/metadata.yaml names {missing}, which is not in the folder"
                ));
            }
            files
        }
        None => names
            .iter()
            .filter(|n| {
                n.rsplit_once('.')
                    .is_some_and(|(_, ext)| STORAGE.contains(&ext.to_ascii_lowercase().as_str()))
            })
            .cloned()
            .collect::<Vec<_>>(),
    };
    // Listings come in the file system's order; errors should not.
    let mut listed = listed;
    listed.sort();
    match listed.as_slice() {
        [one] => Ok(one.clone()),
        [] => Err(format!("{folder}: a folder without a recording (.mcap, .db3 or .bag)")),
        many => Err(format!(
            "{folder}: a split bag of {} files ({}); give one of them, or join them with `ros2 bag convert`",
            many.len(),
            many.join(", ")
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(list: &[&str]) -> Vec<String> {
        list.iter().map(|s| s.to_string()).collect()
    }

    const META: &str = "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: mcap\n  relative_file_paths:\n    - drive_0.mcap\n  duration:\n    nanoseconds: 1\n";

    #[test]
    fn follows_the_metadata() {
        let found = storage_file(
            "drive",
            &names(&["metadata.yaml", "drive_0.mcap", "old.db3"]),
            Some(META),
        );
        assert_eq!(found.unwrap(), "drive_0.mcap");
    }

    #[test]
    fn without_metadata_takes_the_one_recording() {
        let found = storage_file("drive", &names(&["notes.txt", "drive_0.db3"]), None);
        assert_eq!(found.unwrap(), "drive_0.db3");
    }

    #[test]
    fn says_what_is_wrong() {
        let missing = storage_file("drive", &names(&["metadata.yaml"]), Some(META)).unwrap_err();
        assert_eq!(missing, "drive/metadata.yaml names drive_0.mcap, which is not in the folder");
        let split = storage_file("d", &names(&["a_0.mcap", "a_1.mcap"]), None).unwrap_err();
        assert!(split.contains("a split bag of 2 files (a_0.mcap, a_1.mcap)"), "{split}");
        let empty = storage_file("d", &names(&["x.txt"]), None).unwrap_err();
        assert!(empty.contains("without a recording"), "{empty}");
        let bad = storage_file("d", &[], Some("[1, 2")).unwrap_err();
        assert!(bad.starts_with("d/metadata.yaml: not rosbag2 metadata"), "{bad}");
    }
}
