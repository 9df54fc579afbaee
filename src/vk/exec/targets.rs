//! The plan's images (colour, primitive id, depth-stencils, depth textures) and
//! the descriptor sets that sample them. Sampled images are read in
//! `SHADER_READ_ONLY_OPTIMAL`, which the recorder's barriers guarantee.

use std::sync::Arc;

use ash::vk;

use super::ExecDesc;
use crate::plan::usage::Resource;
use crate::vk::conv;
use crate::vk::error::{Check, VkError};
use crate::vk::image::{Image, ImageDesc};
use crate::vk::instance::Shared;
use crate::vk::pipeline::Pipelines;
use crate::vk::sync;

pub(super) struct Targets {
    shared: Arc<Shared>,
    pool: vk::DescriptorPool,
    pub tex_sets: Vec<vk::DescriptorSet>,
    pub ds_sets: Vec<vk::DescriptorSet>,
    pub color: Image,
    pub prim: Image,
    /// The normal buffer, when the executor writes normals.
    pub normal: Option<Image>,
    /// The edge map of the edge pass (with the normal buffer).
    pub edges: Option<Image>,
    /// The descriptor set sampling the normal buffer.
    normal_set: Option<vk::DescriptorSet>,
    /// The transparency accumulation target and the opacity table, when the
    /// executor composites layers ([`Transparency`]).
    pub transparency: Option<Transparency>,
    pub ds: Vec<Image>,
    /// The depth images' format: the set-up's, or its depth-only twin where
    /// the plan uses no stencil (`DepthFormat::vk_for`).
    pub ds_format: vk::Format,
    pub tex: Vec<Image>,
}

impl Drop for Targets {
    fn drop(&mut self) {
        let _layer = self.shared.layer_use();
        // SAFETY: the executor waited for the GPU; destroying the pool frees its sets.
        unsafe { self.shared.device.destroy_descriptor_pool(self.pool, None) };
    }
}

/// The images of the accumulate pass (Hable & Rossignac §6 on the GPU) and the sets
/// that sample its inputs.
pub(super) struct Transparency {
    /// Premultiplied colour (rgb) and coverage (a), blended front to back.
    pub accum: Image,
    /// `ALPHA_TABLE_SIDE`² opacities, primitive id `p` at `(p % side, p / side)`.
    pub alpha: Image,
    pub color_set: vk::DescriptorSet,
    pub prim_set: vk::DescriptorSet,
    pub alpha_set: vk::DescriptorSet,
}

/// Side of the square opacity table: every 16-bit primitive id has a texel.
pub(super) const ALPHA_TABLE_SIDE: u32 = 256;

pub(super) fn format(r: Resource) -> vk::Format {
    match r {
        Resource::Color => vk::Format::R8G8B8A8_UNORM,
        Resource::Prim => vk::Format::R32_UINT,
        // xyz: the seen face's unit normal (world orientation); 0 on background.
        Resource::Normal => vk::Format::R32G32B32A32_SFLOAT,
        // 255 on edges, 0 elsewhere.
        Resource::Edges => vk::Format::R8_UNORM,
        // f32: the composite of many layers stays within rounding of the f64
        // reference's (the device must blend it: `Executor::set_transparency`).
        Resource::Accum => vk::Format::R32G32B32A32_SFLOAT,
        Resource::AlphaTable => vk::Format::R32_SFLOAT,
        Resource::Texture(_) => vk::Format::R32_SFLOAT,
        Resource::DepthStencil(_) => {
            panic!("depth images take the plan's format (Targets::ds_format), not a fixed one")
        }
    }
}

impl Targets {
    /// Fits `n_ds` depth-stencil images of `ds_format` and `n_tex` textures
    /// of `desc`'s size.
    pub fn fits(
        &self,
        n_ds: usize,
        ds_format: vk::Format,
        n_tex: usize,
        normals: bool,
        transparency: bool,
    ) -> bool {
        // Depth-stencil images serve a stencil-free plan too: a sequence of
        // plans of both kinds (layers, a count then a frame) keeps its images
        // rather than making them again at each change.
        let format_fits = self.ds_format == ds_format
            || (conv::has_stencil(self.ds_format) && !conv::has_stencil(ds_format));
        self.ds.len() >= n_ds
            && format_fits
            && self.tex.len() >= n_tex
            && self.normal.is_some() == normals
            && self.transparency.is_some() == transparency
    }

    pub fn new(
        shared: &Arc<Shared>,
        pipelines: &Pipelines,
        desc: &ExecDesc,
        n_ds: usize,
        ds_format: vk::Format,
        n_tex: usize,
        normals: bool,
        transparency: bool,
    ) -> Result<Targets, VkError> {
        let (w, h) = (desc.width, desc.height);
        // Every plan image at the frame's samples: a rendering block's
        // attachments share one count (the normal buffer, edge map and
        // accumulation target are single-sample: refused with samples above 1).
        let ms = desc.samples;
        let sh = shared;
        let color_usage = vk::ImageUsageFlags::COLOR_ATTACHMENT
            | vk::ImageUsageFlags::TRANSFER_SRC
            | vk::ImageUsageFlags::TRANSFER_DST;
        // Sampled: the embedding's composite pass reads colour and ids (vk::embed).
        let out_usage = color_usage | vk::ImageUsageFlags::SAMPLED;
        let color = Image::new(
            sh,
            "color",
            ImageDesc::new_2d(format(Resource::Color), [w, h])
                .usage(out_usage)
                .samples(ms),
        )?;
        let prim = Image::new(
            sh,
            "prim",
            ImageDesc::new_2d(format(Resource::Prim), [w, h])
                .usage(out_usage)
                .samples(ms),
        )?;
        let (normal, edges) = if normals {
            (
                Some(Image::new(
                    sh,
                    "normal",
                    ImageDesc::new_2d(format(Resource::Normal), [w, h])
                        .usage(color_usage | vk::ImageUsageFlags::SAMPLED),
                )?),
                Some(Image::new(
                    sh,
                    "edges",
                    ImageDesc::new_2d(format(Resource::Edges), [w, h]).usage(color_usage),
                )?),
            )
        } else {
            (None, None)
        };
        let mut ds = Vec::new();
        for i in 0..n_ds {
            ds.push(Image::new(
                sh,
                &format!("ds{i}"),
                ImageDesc::new_2d(ds_format, [w, h])
                    .usage(
                        vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT
                            | vk::ImageUsageFlags::SAMPLED
                            | vk::ImageUsageFlags::TRANSFER_SRC
                            | vk::ImageUsageFlags::TRANSFER_DST,
                    )
                    .samples(ms),
            )?);
        }
        let mut tex = Vec::new();
        for i in 0..n_tex {
            tex.push(Image::new(
                sh,
                &format!("tex{i}"),
                ImageDesc::new_2d(vk::Format::R32_SFLOAT, [w, h])
                    .usage(color_usage | vk::ImageUsageFlags::SAMPLED)
                    .samples(ms),
            )?);
        }
        let accum_images = if transparency {
            let side = ALPHA_TABLE_SIDE;
            Some((
                Image::new(
                    sh,
                    "accum",
                    ImageDesc::new_2d(format(Resource::Accum), [w, h]).usage(color_usage),
                )?,
                Image::new(
                    sh,
                    "alpha table",
                    ImageDesc::new_2d(format(Resource::AlphaTable), [side, side]).usage(
                        vk::ImageUsageFlags::SAMPLED
                            | vk::ImageUsageFlags::TRANSFER_SRC
                            | vk::ImageUsageFlags::TRANSFER_DST,
                    ),
                )?,
            ))
        } else {
            None
        };
        // Colour, ids and the opacity table: the accumulate pass's inputs.
        let n_accum_sets = if transparency { 3 } else { 0 };
        let n_sets = (n_ds + n_tex + normals as usize + n_accum_sets) as u32;
        let sizes = [
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::SAMPLED_IMAGE,
                descriptor_count: n_sets.max(1),
            },
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::SAMPLER,
                descriptor_count: n_sets.max(1),
            },
        ];
        let pci = vk::DescriptorPoolCreateInfo::default()
            .max_sets(n_sets.max(1))
            .pool_sizes(&sizes);
        // SAFETY: valid create info.
        let pool = unsafe { sh.device.create_descriptor_pool(&pci, None) }
            .check("vkCreateDescriptorPool")?;
        let mut t = Targets {
            shared: sh.clone(),
            pool,
            tex_sets: Vec::new(),
            ds_sets: Vec::new(),
            color,
            prim,
            normal,
            edges,
            normal_set: None,
            transparency: None,
            ds,
            ds_format,
            tex,
        };
        let layouts = vec![pipelines.set_layout; n_sets as usize];
        let ai = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(pool)
            .set_layouts(&layouts);
        // SAFETY: the pool has room for exactly these sets.
        let sets =
            unsafe { sh.device.allocate_descriptor_sets(&ai) }.check("vkAllocateDescriptorSets")?;
        let views: Vec<vk::ImageView> =
            t.ds.iter()
                .map(|i| i.depth_view)
                .chain(t.tex.iter().map(|i| i.view))
                .chain(t.normal.iter().map(|i| i.view))
                .chain(
                    accum_images
                        .iter()
                        .flat_map(|(_, alpha)| [t.color.view, t.prim.view, alpha.view]),
                )
                .collect();
        let sampled = sync::access(crate::plan::usage::Usage::Sampled).layout;
        for (set, view) in sets.iter().zip(&views) {
            let image_info = [vk::DescriptorImageInfo {
                sampler: vk::Sampler::null(),
                image_view: *view,
                image_layout: sampled,
            }];
            let sampler_info = [vk::DescriptorImageInfo {
                sampler: pipelines.sampler,
                image_view: vk::ImageView::null(),
                image_layout: vk::ImageLayout::UNDEFINED,
            }];
            let writes = [
                vk::WriteDescriptorSet::default()
                    .dst_set(*set)
                    .dst_binding(0)
                    .descriptor_type(vk::DescriptorType::SAMPLED_IMAGE)
                    .image_info(&image_info),
                vk::WriteDescriptorSet::default()
                    .dst_set(*set)
                    .dst_binding(1)
                    .descriptor_type(vk::DescriptorType::SAMPLER)
                    .image_info(&sampler_info),
            ];
            // SAFETY: sets, views and sampler are live; no set is in use.
            unsafe { sh.device.update_descriptor_sets(&writes, &[]) };
        }
        t.ds_sets = sets[..n_ds].to_vec();
        t.tex_sets = sets[n_ds..n_ds + n_tex].to_vec();
        let extra = n_ds + n_tex + normals as usize;
        t.normal_set = normals.then(|| sets[n_ds + n_tex]);
        t.transparency = accum_images.map(|(accum, alpha)| Transparency {
            accum,
            alpha,
            color_set: sets[extra],
            prim_set: sets[extra + 1],
            alpha_set: sets[extra + 2],
        });
        Ok(t)
    }

    pub fn image(&self, r: Resource) -> &Image {
        match r {
            Resource::Color => &self.color,
            Resource::Prim => &self.prim,
            Resource::Normal => self
                .normal
                .as_ref()
                .expect("the normal buffer is used only when the executor writes normals"),
            Resource::Edges => self
                .edges
                .as_ref()
                .expect("the edge map is used only when the executor writes normals"),
            Resource::Accum => &self.transparency().accum,
            Resource::AlphaTable => &self.transparency().alpha,
            Resource::DepthStencil(d) => &self.ds[d as usize],
            Resource::Texture(t) => &self.tex[t as usize],
        }
    }

    pub fn transparency(&self) -> &Transparency {
        self.transparency
            .as_ref()
            .expect("the accumulate pass's images exist only when the executor composites")
    }

    /// Every image, in a fixed order.
    pub fn all(&self) -> Vec<Resource> {
        let mut v = vec![Resource::Color, Resource::Prim];
        v.extend(self.normal.as_ref().map(|_| Resource::Normal));
        v.extend(self.edges.as_ref().map(|_| Resource::Edges));
        if self.transparency.is_some() {
            v.extend([Resource::Accum, Resource::AlphaTable]);
        }
        v.extend((0..self.ds.len() as u8).map(Resource::DepthStencil));
        v.extend((0..self.tex.len() as u8).map(Resource::Texture));
        v
    }

    /// The descriptor set that samples `r` (a texture, or a depth-stencil's depth).
    pub fn sampling_set(&self, r: Resource) -> vk::DescriptorSet {
        match r {
            Resource::DepthStencil(d) => self.ds_sets[d as usize],
            Resource::Texture(t) => self.tex_sets[t as usize],
            Resource::Normal => self
                .normal_set
                .expect("the normal buffer is sampled only when the executor writes normals"),
            // Sampled only by the accumulate pass (plans never sample colour targets).
            Resource::Color => self.transparency().color_set,
            Resource::Prim => self.transparency().prim_set,
            Resource::AlphaTable => self.transparency().alpha_set,
            Resource::Edges | Resource::Accum => {
                panic!("the edge map and the accumulation target are never sampled")
            }
        }
    }
}
