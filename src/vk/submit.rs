//! One-shot submission and the few raw synchronization commands shared by the
//! executor, the read-back and the presenter: a command buffer with its fence,
//! submitted under the queue lock and waited on; barriers; query reads.

use std::sync::Arc;

use ash::vk;

use super::cmd_arena::{ArenaCounts, CmdArena};
use super::error::{Check, VkError};
use super::instance::Shared;

/// A resettable command pool with one primary command buffer and a fence.
/// Its commands live in a [`CmdArena`] (lavapipe allocates each recorded
/// command on the host).
pub struct Submitter {
    shared: Arc<Shared>,
    pool: vk::CommandPool,
    /// The pool's host allocator: boxed (its address is the callbacks' user
    /// data) and dropped after the pool.
    arena: Box<CmdArena>,
    pub cmd: vk::CommandBuffer,
    fence: vk::Fence,
}

impl Submitter {
    pub fn new(shared: &Arc<Shared>) -> Result<Submitter, VkError> {
        let device = &shared.device;
        let pci = vk::CommandPoolCreateInfo::default()
            .queue_family_index(shared.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        let arena = Box::<CmdArena>::default();
        // SAFETY: valid create info on a live device; the arena outlives the
        // pool (destroyed in `drop` with the same callbacks).
        let pool = unsafe { device.create_command_pool(&pci, Some(&arena.callbacks())) }
            .check("vkCreateCommandPool")?;
        let mut s = Submitter {
            shared: shared.clone(),
            pool,
            arena,
            cmd: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
        };
        s.cmd = s.allocate()?;
        // SAFETY: valid create info.
        s.fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }
            .check("vkCreateFence")?;
        Ok(s)
    }

    /// What the pool's host allocator served so far.
    pub fn arena_counts(&self) -> ArenaCounts {
        self.arena.counts()
    }

    /// Another primary command buffer from this pool (freed with it).
    pub fn allocate(&self) -> Result<vk::CommandBuffer, VkError> {
        let ai = vk::CommandBufferAllocateInfo::default()
            .command_pool(self.pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: the pool is live.
        let v = unsafe { self.shared.device.allocate_command_buffers(&ai) }
            .check("vkAllocateCommandBuffers")?;
        Ok(v[0])
    }

    /// Resets `cmd` and begins recording it (`one_time`: submitted once).
    pub fn begin(&self, cmd: vk::CommandBuffer, one_time: bool) -> Result<(), VkError> {
        let device = &self.shared.device;
        // SAFETY: every submission of this pool was waited on, so `cmd` is not pending.
        unsafe { device.reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty()) }
            .check("vkResetCommandBuffer")?;
        let flags = if one_time {
            vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT
        } else {
            vk::CommandBufferUsageFlags::empty()
        };
        let bi = vk::CommandBufferBeginInfo::default().flags(flags);
        // SAFETY: the buffer is in the initial state.
        unsafe { device.begin_command_buffer(cmd, &bi) }.check("vkBeginCommandBuffer")
    }

    /// Ends recording of `cmd`.
    pub fn end(&self, cmd: vk::CommandBuffer) -> Result<(), VkError> {
        // SAFETY: recording state, no open rendering block or query.
        unsafe { self.shared.device.end_command_buffer(cmd) }.check("vkEndCommandBuffer")
    }

    /// Submits the executable `cmd` with the given semaphores, signalling the fence.
    pub fn submit(
        &self,
        cmd: vk::CommandBuffer,
        wait: &[(vk::Semaphore, vk::PipelineStageFlags)],
        signal: &[vk::Semaphore],
    ) -> Result<(), VkError> {
        self.submit_all(&[cmd], wait, signal)
    }

    /// Submits the executable `cmds` in one submission, in order, with the
    /// given semaphores, signalling the fence (several executors' frames at
    /// once: `vk::exec::PreparedFrame`).
    pub fn submit_all(
        &self,
        cmds: &[vk::CommandBuffer],
        wait: &[(vk::Semaphore, vk::PipelineStageFlags)],
        signal: &[vk::Semaphore],
    ) -> Result<(), VkError> {
        let sems: Vec<_> = wait.iter().map(|w| w.0).collect();
        let stages: Vec<_> = wait.iter().map(|w| w.1).collect();
        let si = [vk::SubmitInfo::default()
            .command_buffers(cmds)
            .wait_semaphores(&sems)
            .wait_dst_stage_mask(&stages)
            .signal_semaphores(signal)];
        let _queue = self.shared.queue_lock.lock();
        // SAFETY: the command buffers are executable; the fence is unsignaled; the lock
        // serializes our submissions (an embedding host synchronizes its own, see
        // Context::from_raw).
        unsafe {
            self.shared
                .device
                .queue_submit(self.shared.queue, &si, self.fence)
        }
        .check("vkQueueSubmit")
    }

    /// Waits for the last submission and resets the fence.
    pub fn wait(&self) -> Result<(), VkError> {
        let device = &self.shared.device;
        // SAFETY: the fence was submitted.
        unsafe { device.wait_for_fences(&[self.fence], true, u64::MAX) }
            .check("vkWaitForFences")?;
        // SAFETY: the fence is signaled and not in use.
        unsafe { device.reset_fences(&[self.fence]) }.check("vkResetFences")
    }

    /// Ends, submits and waits for `cmd`.
    pub fn finish(&self, cmd: vk::CommandBuffer) -> Result<(), VkError> {
        self.end(cmd)?;
        self.submit(cmd, &[], &[])?;
        self.wait()
    }
}

impl Drop for Submitter {
    fn drop(&mut self) {
        let _layer = self.shared.layer_use();
        let d = &self.shared.device;
        // SAFETY: every submission was waited on (`finish`/`wait`), so nothing is
        // pending; destroying the pool frees its command buffers; null is ignored.
        unsafe { d.destroy_fence(self.fence, None) };
        // SAFETY: as above; the pool was created with these callbacks.
        unsafe { d.destroy_command_pool(self.pool, Some(&self.arena.callbacks())) };
    }
}

/// A global memory barrier.
/// Makes transfer writes (copies into a read-back buffer) visible to the host.
pub fn transfer_to_host_barrier(device: &ash::Device, cmd: vk::CommandBuffer) {
    memory_barrier(
        device,
        cmd,
        (
            vk::PipelineStageFlags::TRANSFER,
            vk::AccessFlags::TRANSFER_WRITE,
        ),
        (vk::PipelineStageFlags::HOST, vk::AccessFlags::HOST_READ),
    );
}

pub fn memory_barrier(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    src: (vk::PipelineStageFlags, vk::AccessFlags),
    dst: (vk::PipelineStageFlags, vk::AccessFlags),
) {
    let barrier = [vk::MemoryBarrier::default()
        .src_access_mask(src.1)
        .dst_access_mask(dst.1)];
    pipeline_barrier(device, cmd, (src.0, dst.0), &barrier, &[]);
}

/// Image barriers in one command, with the union of their stages.
pub fn image_barriers(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    src_stage: vk::PipelineStageFlags,
    dst_stage: vk::PipelineStageFlags,
    barriers: &[vk::ImageMemoryBarrier],
) {
    pipeline_barrier(device, cmd, (src_stage, dst_stage), &[], barriers);
}

/// Global and image barriers in one command (`stages`: source and destination,
/// the union of theirs).
pub fn pipeline_barrier(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    stages: (vk::PipelineStageFlags, vk::PipelineStageFlags),
    memory: &[vk::MemoryBarrier],
    images: &[vk::ImageMemoryBarrier],
) {
    // SAFETY: recording, outside rendering (callers end it first); the images
    // are live and in the old layouts the barriers name.
    unsafe {
        device.cmd_pipeline_barrier(
            cmd,
            stages.0,
            stages.1,
            vk::DependencyFlags::empty(),
            memory,
            &[],
            images,
        )
    };
}

/// The first `n` results of `pool`, written by a submission that has completed.
pub fn query_results(
    device: &ash::Device,
    pool: vk::QueryPool,
    n: usize,
) -> Result<Vec<u64>, VkError> {
    let mut out = vec![0u64; n];
    if n == 0 {
        return Ok(out);
    }
    // SAFETY: the first `n` queries were written by the completed submission.
    unsafe {
        device.get_query_pool_results(
            pool,
            0,
            &mut out,
            vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
        )
    }
    .check("vkGetQueryPoolResults")?;
    Ok(out)
}

/// A query pool that grows to the largest need (powers of two, so plans of one
/// size reuse it).
pub struct Queries {
    shared: Arc<Shared>,
    ty: vk::QueryType,
    pub pool: vk::QueryPool,
    pub cap: u32,
    /// Pools replaced by a larger one, destroyed with this one: an embedding
    /// host may still have frames pending that use them (at most one per
    /// doubling).
    retired: Vec<vk::QueryPool>,
}

impl Queries {
    pub fn new(shared: &Arc<Shared>, ty: vk::QueryType) -> Queries {
        Queries {
            shared: shared.clone(),
            ty,
            pool: vk::QueryPool::null(),
            cap: 0,
            retired: Vec::new(),
        }
    }

    /// Makes room for `need` queries; returns whether the pool was replaced (a
    /// recording that uses the old one must not be replayed).
    pub fn ensure(&mut self, need: u32) -> Result<bool, VkError> {
        let need = need.max(1);
        if need <= self.cap {
            return Ok(false);
        }
        let device = &self.shared.device;
        if self.pool != vk::QueryPool::null() {
            self.retired.push(self.pool);
        }
        self.pool = vk::QueryPool::null();
        self.cap = 0;
        let new_cap = need.next_power_of_two();
        let ci = vk::QueryPoolCreateInfo::default()
            .query_type(self.ty)
            .query_count(new_cap);
        // SAFETY: valid create info.
        self.pool = unsafe { device.create_query_pool(&ci, None) }.check("vkCreateQueryPool")?;
        self.cap = new_cap;
        Ok(true)
    }
}

impl Drop for Queries {
    fn drop(&mut self) {
        let _layer = self.shared.layer_use();
        for p in self.retired.drain(..).chain([self.pool]) {
            // SAFETY: no submission using the pools is pending (their owners wait
            // for, or outlive, every frame); null is ignored.
            unsafe { self.shared.device.destroy_query_pool(p, None) };
        }
    }
}
