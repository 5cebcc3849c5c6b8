//! `dvsgi view --script FILE`: drives the viewer without input, a command per line, so a test
//! (or a user making a figure) can move the camera, switch techniques and capture.
//!
//! ```text
//! # comment
//! frames 10                         render 10 frames
//! camera 0.3 0.3 -0.8  0.3 0.3 0    place the eye at (x y z), looking at (x y z)
//! turn 15 -5                        turn by (yaw, pitch) degrees
//! fly 1 0 0 0.5                     fly (forward right up) for 0.5 s of scene time
//! orbit | fly-mode                  camera mode
//! set gi.diffuse_cones=4            any scene setting (as --set)
//! gi lpv | schedule sync | preset low | view indirect
//! pause | play                      stop or restart scene time
//! capture out/shot                  out/shot.png, .exr, .toml and -window.png
//! resize 640 360                    resize the window
//! memory                            print GPU and resident memory
//! quit
//! ```

use super::ViewError;
use crate::render::Mode;
use crate::scene::Preset;
use glam::Vec3;
use std::path::{Path, PathBuf};

/// One command of a script.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    Frames(u32),
    Camera {
        position: Vec3,
        target: Vec3,
    },
    Turn {
        yaw_deg: f32,
        pitch_deg: f32,
    },
    Fly {
        forward: f32,
        right: f32,
        up: f32,
        seconds: f32,
    },
    Orbit,
    FlyMode,
    Set {
        key: String,
        value: String,
    },
    Schedule(Mode),
    Preset(Preset),
    Pause(bool),
    Capture(PathBuf),
    Resize {
        width: u32,
        height: u32,
    },
    /// Print the GPU allocator's bytes and the resident memory (leak checks).
    Memory,
    Quit,
}

/// A parsed script: its commands with their line numbers, and where it is.
#[derive(Debug)]
pub struct Script {
    pub path: PathBuf,
    commands: Vec<(usize, Command)>,
    next: usize,
    /// Frames left of the current `frames` command.
    frames_left: u32,
}

impl Script {
    /// Read and parse `path`; an error names the file, the line and what is wrong.
    pub fn load(path: &Path) -> Result<Script, ViewError> {
        let text = std::fs::read_to_string(path).map_err(|e| ViewError::Script {
            path: path.to_path_buf(),
            line: 0,
            message: e.to_string(),
        })?;
        Script::parse(path, &text)
    }

    pub fn parse(path: &Path, text: &str) -> Result<Script, ViewError> {
        let mut commands = Vec::new();
        for (i, raw) in text.lines().enumerate() {
            let line = raw.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let command = parse_line(line).map_err(|message| ViewError::Script {
                path: path.to_path_buf(),
                line: i + 1,
                message,
            })?;
            commands.push((i + 1, command));
        }
        Ok(Script { path: path.to_path_buf(), commands, next: 0, frames_left: 0 })
    }

    /// The commands to carry out before the next frame, up to the one that renders it (a
    /// `frames` count in progress renders one frame per call). Empty at the end of the script.
    pub fn step(&mut self) -> Vec<Command> {
        let mut out = Vec::new();
        if self.frames_left > 0 {
            self.frames_left -= 1;
            return vec![Command::Frames(1)];
        }
        while let Some((_, c)) = self.commands.get(self.next).cloned() {
            self.next += 1;
            match c {
                Command::Frames(n) if n > 0 => {
                    self.frames_left = n - 1;
                    out.push(Command::Frames(1));
                    return out;
                }
                Command::Frames(_) => {}
                c @ (Command::Capture(_) | Command::Quit) => {
                    out.push(c);
                    return out;
                }
                c => out.push(c),
            }
        }
        out
    }

    /// The output stems of its captures (to check before any work).
    pub fn captures(&self) -> impl Iterator<Item = &Path> {
        self.commands.iter().filter_map(|(_, c)| if let Command::Capture(p) = c { Some(p.as_path()) } else { None })
    }

    /// Whether every command has been handed out.
    pub fn done(&self) -> bool {
        self.next >= self.commands.len() && self.frames_left == 0
    }
}

/// One non-empty line, without its comment.
fn parse_line(line: &str) -> Result<Command, String> {
    let mut words = line.split_whitespace();
    let verb = words.next().unwrap_or("");
    let args: Vec<&str> = words.collect();
    let one = |what: &str| -> Result<&str, String> {
        match args.as_slice() {
            [a] => Ok(*a),
            _ => Err(format!("`{verb}` takes one argument ({what})")),
        }
    };
    Ok(match verb {
        "frames" => Command::Frames(one("a frame count")?.parse().map_err(|_| "`frames` takes a whole number")?),
        "camera" => {
            let v = numbers(verb, &args, 6)?;
            Command::Camera { position: Vec3::new(v[0], v[1], v[2]), target: Vec3::new(v[3], v[4], v[5]) }
        }
        "turn" => {
            let v = numbers(verb, &args, 2)?;
            Command::Turn { yaw_deg: v[0], pitch_deg: v[1] }
        }
        "fly" => {
            let v = numbers(verb, &args, 4)?;
            Command::Fly { forward: v[0], right: v[1], up: v[2], seconds: v[3] }
        }
        "orbit" => Command::Orbit,
        "fly-mode" => Command::FlyMode,
        "set" => {
            let (key, value) = one("KEY=VALUE")?.split_once('=').ok_or("`set` takes KEY=VALUE")?;
            Command::Set { key: key.to_string(), value: value.to_string() }
        }
        "gi" => Command::Set { key: "gi.mode".into(), value: format!("{:?}", one("a technique")?) },
        "view" => Command::Set { key: "render.view".into(), value: format!("{:?}", one("a view")?) },
        "schedule" => Command::Schedule(one("sync | async | async-lagged | async-pipelined")?.parse()?),
        "preset" => Command::Preset(preset(one(&preset_names())?)?),
        "pause" => Command::Pause(true),
        "play" => Command::Pause(false),
        "capture" => Command::Capture(PathBuf::from(one("an output path without extension")?)),
        "resize" => {
            let v = numbers(verb, &args, 2)?;
            if v.iter().any(|x| *x < 1.0 || x.fract() != 0.0) {
                return Err("`resize` takes a width and height in whole pixels >= 1".into());
            }
            Command::Resize { width: v[0] as u32, height: v[1] as u32 }
        }
        "memory" => Command::Memory,
        "quit" => Command::Quit,
        _ => return Err(format!("unknown command `{verb}`: see `dvsgi view --help`")),
    })
}

/// Exactly `n` finite numbers.
fn numbers(verb: &str, args: &[&str], n: usize) -> Result<Vec<f32>, String> {
    let v: Vec<f32> = args.iter().filter_map(|a| a.parse::<f32>().ok()).filter(|x| x.is_finite()).collect();
    if args.len() != n || v.len() != n {
        return Err(format!("`{verb}` takes {n} numbers"));
    }
    Ok(v)
}

fn preset(s: &str) -> Result<Preset, String> {
    use clap::ValueEnum;
    Preset::from_str(s, true).map_err(|_| format!("unknown preset `{s}`: {}", preset_names()))
}

/// `low | medium | ...`: every preset, as the command line spells them.
fn preset_names() -> String {
    use clap::ValueEnum;
    Preset::value_variants()
        .iter()
        .filter_map(|p| p.to_possible_value().map(|v| v.get_name().to_owned()))
        .collect::<Vec<_>>()
        .join(" | ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Script, ViewError> {
        Script::parse(Path::new("s.txt"), text)
    }

    #[test]
    fn a_script_hands_out_one_frame_at_a_time_and_stops_at_captures() {
        let mut s = parse("# warm up\nframes 2\ngi lpv\nschedule sync\ncapture out/a\nquit\n").unwrap();
        assert_eq!(s.step(), vec![Command::Frames(1)]);
        assert_eq!(s.step(), vec![Command::Frames(1)]);
        let set = Command::Set { key: "gi.mode".into(), value: "\"lpv\"".into() };
        assert_eq!(s.step(), vec![set, Command::Schedule(Mode::Sync), Command::Capture("out/a".into())]);
        assert!(!s.done());
        assert_eq!(s.step(), vec![Command::Quit]);
        assert!(s.done());
        assert_eq!(s.step(), vec![]);
    }

    #[test]
    fn errors_name_the_file_and_line() {
        let e = parse("frames 1\n\ncamera 1 2 3\n").unwrap_err().to_string();
        assert!(e.contains("s.txt") && e.contains("line 3") && e.contains("`camera` takes 6 numbers"), "{e}");
        let e = parse("jump\n").unwrap_err().to_string();
        assert!(e.contains("line 1") && e.contains("unknown command `jump`"), "{e}");
        let e = parse("schedule later\n").unwrap_err().to_string();
        assert!(e.contains("line 1") && e.contains("later"), "{e}");
        assert!(parse("resize 0 10").is_err() && parse("fly 1 0 0 nan").is_err() && parse("set x").is_err());
        let e = parse("preset extreme\n").unwrap_err().to_string();
        assert!(e.contains("unknown preset `extreme`: low | medium | high | ultra | max"), "{e}");
        assert_eq!(parse("preset MAX\n").unwrap().commands[0].1, Command::Preset(Preset::Max));
    }

    #[test]
    fn every_command_parses() {
        let s = parse(
            "camera 0 0 -1 0 0 0\nturn 10 -5\nfly 1 0 0 0.5\norbit\nfly-mode\nset gi.bounces=2\nview ao\n\
             preset low\npause\nplay\nresize 64 32\n",
        )
        .unwrap();
        assert_eq!(s.commands.len(), 11);
        assert_eq!(s.commands[10].1, Command::Resize { width: 64, height: 32 });
        assert_eq!(s.commands[7].1, Command::Preset(Preset::Low));
    }
}
