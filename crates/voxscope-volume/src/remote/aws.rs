//! AWS credentials and settings from the shared files, where the environment gives none.

use std::collections::HashMap;
use std::path::PathBuf;

use object_store::aws::{AmazonS3Builder, AmazonS3ConfigKey};

use super::super::error::escape;

/// What the environment and `~/.aws` give.
pub(super) struct Credentials {
    /// Settings from the profile, to apply where the environment has none.
    from_files: Vec<(AmazonS3ConfigKey, String)>,
    /// No credentials anywhere: requests go unsigned (public buckets).
    anonymous: bool,
    secrets: Vec<String>,
    /// The S3 endpoint, where one is given.
    endpoint: Option<Endpoint>,
}

/// An S3 endpoint as given, unchecked (whitespace around it kept), and where it was given: a
/// variable's name, or the config file's setting.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct Endpoint {
    pub(super) value: String,
    pub(super) source: String,
}

/// The variables that give an S3 endpoint, the first set (and not blank) winning:
/// object_store's own order (the S3-only one over the generic ones), `AWS_ENDPOINT_URL` (the
/// AWS tools' name) over `AWS_ENDPOINT` (object_store's older one).
pub(super) const ENDPOINT_VARIABLES: [&str; 3] =
    ["AWS_ENDPOINT_URL_S3", "AWS_ENDPOINT_URL", "AWS_ENDPOINT"];

/// A variable of the process's environment, if set and not blank.
fn process_env(name: &str) -> Option<String> {
    std::env::var(name).ok().filter(|v| !v.trim().is_empty())
}

/// `[section]` → key → value of an INI file (the AWS shared files' format).
fn ini(path: &PathBuf) -> HashMap<String, HashMap<String, String>> {
    let mut sections: HashMap<String, HashMap<String, String>> = HashMap::new();
    let Ok(text) = std::fs::read_to_string(path) else {
        return sections;
    };
    let mut current = String::new();
    for line in text.lines().map(str::trim) {
        if line.starts_with('#') || line.starts_with(';') || line.is_empty() {
            continue;
        }
        if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            current = name.trim().to_owned();
        } else if let Some((key, value)) = line.split_once('=') {
            sections
                .entry(current.clone())
                .or_default()
                .insert(key.trim().to_ascii_lowercase(), value.trim().to_owned());
        }
    }
    sections
}

impl Credentials {
    /// Looks at the environment, then at the profile of the shared files.
    pub(super) fn find() -> Self {
        Self::find_with(&process_env, std::env::home_dir())
    }

    /// [`Self::find`] with the environment `env` and the home folder `home`.
    pub(super) fn find_with(env: &dyn Fn(&str) -> Option<String>, home: Option<PathBuf>) -> Self {
        let home_file = |variable: &str, name: &str| {
            env(variable)
                .map(PathBuf::from)
                .or_else(|| home.as_ref().map(|home| home.join(".aws").join(name)))
        };
        let profile = env("AWS_PROFILE").unwrap_or_else(|| "default".to_owned());
        let credentials = home_file("AWS_SHARED_CREDENTIALS_FILE", "credentials")
            .map(|p| ini(&p))
            .unwrap_or_default();
        let config_path = home_file("AWS_CONFIG_FILE", "config");
        let config = config_path.as_ref().map(ini).unwrap_or_default();
        let config_section = if profile == "default" {
            "default".to_owned()
        } else {
            format!("profile {profile}")
        };
        let empty: HashMap<String, String> = HashMap::new();
        let keys = credentials.get(&profile).unwrap_or(&empty);
        let settings = config.get(&config_section).unwrap_or(&empty);
        let mut from_files = Vec::new();
        let env_keys = env("AWS_ACCESS_KEY_ID").is_some();
        if !env_keys {
            for (name, key) in [
                ("aws_access_key_id", AmazonS3ConfigKey::AccessKeyId),
                ("aws_secret_access_key", AmazonS3ConfigKey::SecretAccessKey),
                ("aws_session_token", AmazonS3ConfigKey::Token),
            ] {
                if let Some(value) = keys.get(name).or_else(|| settings.get(name)) {
                    from_files.push((key, value.clone()));
                }
            }
        }
        if env("AWS_REGION").is_none()
            && env("AWS_DEFAULT_REGION").is_none()
            && let Some(region) = settings.get("region")
        {
            from_files.push((AmazonS3ConfigKey::Region, region.clone()));
        }
        let endpoint = ENDPOINT_VARIABLES
            .iter()
            .find_map(|&name| {
                let value = env(name).filter(|value| !value.trim().is_empty())?;
                Some(Endpoint {
                    value,
                    source: name.to_owned(),
                })
            })
            .or_else(|| {
                let value = settings.get("endpoint_url")?.clone();
                let path = config_path.as_ref()?;
                Some(Endpoint {
                    value,
                    source: format!(
                        "endpoint_url of [{config_section}] in {}",
                        escape(&path.display().to_string())
                    ),
                })
            });
        let file_keys = from_files
            .iter()
            .any(|(key, _)| matches!(key, AmazonS3ConfigKey::AccessKeyId));
        // Web identity and container credentials are object_store's own providers; with
        // none of them, no keys means anonymous (never the EC2 metadata service, which
        // does not answer off EC2 and would hold every open for seconds).
        let provider = [
            "AWS_WEB_IDENTITY_TOKEN_FILE",
            "AWS_CONTAINER_CREDENTIALS_RELATIVE_URI",
            "AWS_CONTAINER_CREDENTIALS_FULL_URI",
        ]
        .iter()
        .any(|name| env(name).is_some());
        let anonymous = !env_keys && !file_keys && !provider;
        let secrets = ["AWS_SECRET_ACCESS_KEY", "AWS_SESSION_TOKEN"]
            .iter()
            .filter_map(|name| env(name))
            .chain(
                from_files
                    .iter()
                    .filter(|(key, _)| {
                        matches!(
                            key,
                            AmazonS3ConfigKey::SecretAccessKey | AmazonS3ConfigKey::Token
                        )
                    })
                    .map(|(_, value)| value.clone()),
            )
            .filter(|s| s.len() >= 3)
            .collect();
        Self {
            from_files,
            anonymous,
            secrets,
            endpoint,
        }
    }

    /// The S3 endpoint the environment gives (the first of [`ENDPOINT_VARIABLES`] that is
    /// set and not blank), else the profile's `endpoint_url`.
    pub(super) fn endpoint(&self) -> Option<&Endpoint> {
        self.endpoint.as_ref()
    }

    /// Whether requests go unsigned.
    #[cfg(test)]
    pub(super) fn anonymous(&self) -> bool {
        self.anonymous
    }

    /// The value of `key` the files give (where the environment gives none).
    #[cfg(test)]
    pub(super) fn setting(&self, key: AmazonS3ConfigKey) -> Option<&str> {
        self.from_files
            .iter()
            .find(|(k, _)| *k == key)
            .map(|(_, v)| v.as_str())
    }

    /// The secret strings found (to blank out of messages).
    pub(super) fn secrets(&self) -> Vec<String> {
        self.secrets.clone()
    }

    /// `builder` with the files' settings, and unsigned requests without credentials.
    pub(super) fn apply(&self, mut builder: AmazonS3Builder) -> AmazonS3Builder {
        for (key, value) in &self.from_files {
            builder = builder.with_config(*key, value);
        }
        if self.anonymous {
            builder = builder.with_skip_signature(true);
        }
        builder
    }
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::*;

    #[test]
    fn credentials_come_from_the_environment_then_the_profile_else_none() {
        use object_store::aws::AmazonS3ConfigKey as Key;
        let home = tempfile::tempdir().expect("a temporary folder");
        let aws = home.path().join(".aws");
        std::fs::create_dir_all(&aws).expect("~/.aws");
        std::fs::write(
            aws.join("credentials"),
            "[default]\naws_access_key_id = AKIDEFAULT\naws_secret_access_key = defaultsecret\n\n\
             [lab]\naws_access_key_id=AKILAB\naws_secret_access_key=labsecret\n",
        )
        .expect("credentials");
        std::fs::write(
            aws.join("config"),
            "[profile lab]\nregion = eu-west-3\nendpoint_url = http://127.0.0.1:9000\n",
        )
        .expect("config");
        let found = |vars: &[(&str, &str)], home: Option<PathBuf>| {
            let vars: Vec<(String, String)> = vars
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect();
            Credentials::find_with(
                &move |name: &str| vars.iter().find(|(k, _)| k == name).map(|(_, v)| v.clone()),
                home,
            )
        };
        let home_path = Some(home.path().to_path_buf());
        let lab = found(&[("AWS_PROFILE", "lab")], home_path.clone());
        assert!(!lab.anonymous());
        assert_eq!(lab.setting(Key::AccessKeyId), Some("AKILAB"));
        assert_eq!(lab.setting(Key::Region), Some("eu-west-3"));
        let config = aws.join("config").display().to_string();
        assert_eq!(
            lab.endpoint(),
            Some(&Endpoint {
                value: "http://127.0.0.1:9000".to_owned(),
                source: format!("endpoint_url of [profile lab] in {config}"),
            })
        );
        assert_eq!(lab.secrets(), vec!["labsecret".to_owned()]);
        let default = found(&[], home_path.clone());
        assert_eq!(default.setting(Key::AccessKeyId), Some("AKIDEFAULT"));
        assert_eq!(default.setting(Key::Region), None);
        // The environment's keys win over the files'; its region and endpoint too.
        let env = found(
            &[
                ("AWS_ACCESS_KEY_ID", "AKIENV"),
                ("AWS_SECRET_ACCESS_KEY", "envsecret"),
                ("AWS_PROFILE", "lab"),
                ("AWS_REGION", "us-west-2"),
            ],
            home_path,
        );
        assert!(!env.anonymous());
        assert_eq!(env.setting(Key::AccessKeyId), None);
        assert_eq!(env.setting(Key::Region), None);
        // No endpoint variable: the profile's.
        assert_eq!(env.endpoint(), lab.endpoint());
        // The environment's endpoint wins over the profile's, the S3-only variable over the
        // others; a blank one is none.
        let endpoint = |vars: &[(&str, &str)]| {
            let mut vars = vars.to_vec();
            vars.push(("AWS_PROFILE", "lab"));
            found(&vars, Some(home.path().to_path_buf()))
                .endpoint()
                .map(|e| (e.source.clone(), e.value.clone()))
        };
        let named = |source: &str, value: &str| Some((source.to_owned(), value.to_owned()));
        assert_eq!(
            endpoint(&[
                ("AWS_ENDPOINT", "http://b:2"),
                ("AWS_ENDPOINT_URL", "http://a:1 ")
            ]),
            named("AWS_ENDPOINT_URL", "http://a:1 ")
        );
        assert_eq!(
            endpoint(&[
                ("AWS_ENDPOINT_URL", "http://a:1"),
                ("AWS_ENDPOINT_URL_S3", "http://s:3")
            ]),
            named("AWS_ENDPOINT_URL_S3", "http://s:3")
        );
        assert_eq!(
            endpoint(&[
                ("AWS_ENDPOINT", "http://b:2"),
                ("AWS_ENDPOINT_URL", " \r\n")
            ]),
            named("AWS_ENDPOINT", "http://b:2")
        );
        assert_eq!(
            endpoint(&[("AWS_ENDPOINT_URL", "\r")]),
            named(
                &format!("endpoint_url of [profile lab] in {config}"),
                "http://127.0.0.1:9000"
            )
        );
        assert_eq!(env.secrets(), vec!["envsecret".to_owned()]);
        // Nothing anywhere: anonymous.
        assert!(found(&[], None).anonymous());
        let shared = tempfile::NamedTempFile::new().expect("a file");
        let nowhere = found(
            &[(
                "AWS_SHARED_CREDENTIALS_FILE",
                shared.path().to_str().unwrap_or_default(),
            )],
            None,
        );
        assert!(nowhere.anonymous());
    }
}
