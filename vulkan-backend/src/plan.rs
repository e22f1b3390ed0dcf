//! Planning GPU work: which dispatches (and barriers between them) cover a launch's ids. Pure
//! functions, so the split is unit-tested without a device.

use super::kernels::PushConstants;
use shared::kernels::launch::WORKGROUP_SIZE;
use std::ops::Range;

/// One step of a submission, as the caller describes it.
pub enum Step<P> {
    /// Run the kernel over `ids` with `push` (its launch header is filled in per dispatch).
    Run { push: P, ids: Range<u32> },
    /// Later steps read what earlier ones wrote: wait for them.
    Barrier,
}

/// One command of a planned submission.
#[derive(Debug, PartialEq)]
pub enum Command<P> {
    /// `vkCmdPushConstants(push)` then `vkCmdDispatch(groups, 1, 1)`.
    Dispatch { push: P, groups: u32 },
    /// A compute-to-compute memory barrier.
    Barrier,
}

/// The commands for `steps`: each `Run` split into dispatches of at most `max_groups`
/// workgroups, dispatch k covering ids `offset..offset + n` (`launch.offset`, `launch.count`),
/// its workgroups interleaved over `interleave` threads (`launch.interleave`, see
/// [`shared::kernels::launch::interleaved_group`]).
pub fn plan<P: PushConstants>(
    steps: Vec<Step<P>>,
    max_groups: u32,
    interleave: u32,
) -> Vec<Command<P>> {
    let chunk = max_groups.max(1) * WORKGROUP_SIZE;
    let mut commands = Vec::new();
    for step in steps {
        match step {
            Step::Barrier => commands.push(Command::Barrier),
            Step::Run { push, ids } => {
                let mut offset = ids.start;
                while offset < ids.end {
                    let n = (ids.end - offset).min(chunk);
                    let mut push = push;
                    let launch = push.launch_mut();
                    launch.offset = offset;
                    launch.count = offset + n;
                    launch.interleave = interleave;
                    commands.push(Command::Dispatch {
                        push,
                        groups: n.div_ceil(WORKGROUP_SIZE),
                    });
                    offset += n;
                }
            }
        }
    }
    commands
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::kernels::launch::Launch;

    /// The (offset, count, groups) of each dispatch, `None` for a barrier.
    fn shape(c: &[Command<Launch>]) -> Vec<Option<(u32, u32, u32)>> {
        c.iter()
            .map(|c| match c {
                Command::Dispatch { push, groups } => Some((push.offset, push.count, *groups)),
                Command::Barrier => None,
            })
            .collect()
    }

    #[test]
    fn runs_split_at_the_workgroup_limit_and_keep_seed_and_barriers() {
        let push = Launch {
            seed: 7,
            ..Default::default()
        };
        let steps = vec![
            Step::Run { push, ids: 10..300 },
            Step::Barrier,
            Step::Run { push, ids: 0..0 },
            Step::Run { push, ids: 0..64 },
        ];
        let commands = plan(steps, 2, 3);
        assert_eq!(
            shape(&commands),
            vec![
                Some((10, 138, 2)),
                Some((138, 266, 2)),
                Some((266, 300, 1)),
                None,
                Some((0, 64, 1)),
            ]
        );
        assert!(commands.iter().all(|c| match c {
            Command::Dispatch { push, .. } => push.seed == 7 && push.interleave == 3,
            Command::Barrier => true,
        }));
    }

    #[test]
    fn the_last_id_of_u32_is_reached_without_overflow() {
        let steps = vec![Step::Run {
            push: Launch::default(),
            ids: u32::MAX - 100..u32::MAX,
        }];
        let commands = plan(steps, 65_535, 1);
        assert_eq!(shape(&commands), vec![Some((u32::MAX - 100, u32::MAX, 2))]);
    }
}
