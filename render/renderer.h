#pragma once
// The one entry point of render/ for the service: it owns the backends, knows which
// serves which work (tiles, large frames, mixes, surface points, mesh previews) and falls back
// to the CPU path where a backend has none (a mix's limit levels, surfaces beyond the GPU's
// range, everything when no GPU was found). server/ never sees a backend type.
#include "core/result.h"
#include "render/backend.h"
#include "render/backend_factory.h"
#include "render/surface_eval.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace textond::render {

class CpuBackend;
class PreparedSplat;
class GlBackend;
class WindowBatcher;

class Renderer {
public:
    enum class Work { tile, frame }; // a tile: one small window of many at once; a frame: large

    // `options.threads` for frames on the CPU (tiles take one thread each).
    static Result<std::unique_ptr<Renderer>> make(BackendKind kind, const BackendOptions& options);
    ~Renderer();

    // Each evaluation says in `used` (when given) which backend ran it.
    Result<core::Image> noise(const PreparedTexton& texton, const NoiseRequest& request, Work work,
                              std::string* used = nullptr);
    // A material set's normal map from its height map (render/normal_map.h), on the CPU.
    Result<core::Image> normals(const PreparedTexton& height, const NoiseRequest& request,
                                double strength, Work work);
    Result<core::Image> mix(const PreparedMix& mix, const NoiseRequest& request, Work work,
                            std::string* used = nullptr);
    // A splat map (render/prepared_splat.h): each layer a window of its texton on the backend
    // `work` picks, blended on the CPU (render/renderer_splat.cpp). Large windows go in strips.
    Result<core::Image> splat(const PreparedSplat& splat, const NoiseRequest& request, Work work,
                              std::string* used = nullptr);
    // Its normalised weights at every pixel of the window, one channel a layer.
    Result<core::Image> splat_weights(const PreparedSplat& splat, const NoiseRequest& request,
                                      Work work);
    // Surface noise at points (texels per unit in req.scale); colours per point, the texton's
    // channels each.
    Result<std::vector<float>> surface(const PreparedTexton& texton, const SurfaceRequest& req,
                                       const std::vector<float>& points,
                                       const std::vector<float>& normals,
                                       std::string* used = nullptr);
    // With relief (a set's height bending the normals) on the CPU, which alone has it.
    Result<core::Image> mesh_preview(const PreparedTexton& texton, const SurfaceRequest& req,
                                     const Mesh& mesh, const Camera& camera, int width, int height,
                                     std::string* used = nullptr, const Relief& relief = {});

    const std::string& tiles_backend() const { return m_tiles_name; }
    // How much more CPU the work takes here than the CPU path's admission estimate says: 1, or
    // llvmpipe's measured factor when GL runs in software (OSMesa, or EGL without a GPU).
    double work_factor() const;
    // Whether all noise (tiles and frames) goes through a GL batcher, and what it did: batches
    // and windows in them.
    bool all_batched() const; // tiles and frames
    int gl_lanes() const;     // the batcher's workers, each with a context (0: no batcher)
    std::uint64_t batches() const;
    std::uint64_t batched_windows() const;
    const std::string& frames_backend() const { return m_frames_name; }
    std::string renderer() const { return m_frames->renderer(); }
    // What was tried and why these were taken; what `auto` measured.
    const std::string& reason() const { return m_reason; }
    const std::vector<Calibration>& calibration() const { return m_calibration; }
    // Part of every ETag: the backends whose bits the images are (the CPU's are the same for any
    // thread count and instruction set).
    const std::string& identity() const { return m_identity; }

private:
    Renderer() = default;
    std::shared_ptr<Backend> m_tiles, m_frames;
    std::string m_tiles_name, m_frames_name;
    std::shared_ptr<CpuBackend> m_cpu_one, m_cpu_all; // mixes' limit levels, fallbacks
    std::shared_ptr<GlBackend> m_gl;                  // surfaces and meshes, when frames are GL
    // Every noise window bound for a GL backend (tiles and frames, mixes too) goes through its
    // batcher.
    std::shared_ptr<GlBackend> m_batched;
    std::unique_ptr<WindowBatcher> m_batcher;
    Result<core::Image> on(Backend& b, const PreparedTexton& texton, const PreparedMix* mix,
                           const NoiseRequest& request);
    std::string m_reason, m_identity;
    std::vector<Calibration> m_calibration;
};

} // namespace textond::render
