//! AWS credentials and settings from the shared files, where the environment gives none.

use std::collections::HashMap;
use std::path::PathBuf;

use object_store::aws::{AmazonS3Builder, AmazonS3ConfigKey};

/// What the environment and `~/.aws` give.
pub(super) struct Credentials {
    /// Settings from the profile, to apply where the environment has none.
    from_files: Vec<(AmazonS3ConfigKey, String)>,
    /// No credentials anywhere: requests go unsigned (public buckets).
    anonymous: bool,
    secrets: Vec<String>,
}

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
        let config = home_file("AWS_CONFIG_FILE", "config")
            .map(|p| ini(&p))
            .unwrap_or_default();
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
        if env("AWS_ENDPOINT_URL").is_none()
            && env("AWS_ENDPOINT").is_none()
            && let Some(endpoint) = settings.get("endpoint_url")
        {
            from_files.push((AmazonS3ConfigKey::Endpoint, endpoint.clone()));
        }
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
        }
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
