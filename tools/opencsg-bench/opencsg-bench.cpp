// opencsg-bench: renders one scene exported by `peeltrim bench --baseline opencsg`
// with OpenCSG 1.5, driven as OpenSCAD's preview drives it, and writes each
// variant's timings and images for peeltrim to compare against its reference.
//
// OpenCSG is GPL; this program is separate from peeltrim and never linked into
// its library or binary. Build: tools/opencsg-bench/build.sh.
//
// Usage: opencsg-bench SCENE.txt OUTDIR [--frames N] [--warmup N] [--no-bbox]
//                      [--variants scs,goldfeather,automatic]
//
// Input (whitespace-separated text, written by peeltrim; see docs/bench.md):
//   peeltrim-opencsg 1
//   size W H
//   view m00 m10 ... (16 floats, column-major, GL convention)
//   proj (16 floats, column-major, GL convention: depth -1..1, y up)
//   prims N
//   prim CONVEXITY R G B  X0 Y0 Z0 X1 Y1 Z1  T      (NDC box; CONVEXITY 0: measure)
//     then 9*T floats: world-space triangles, counter-clockwise from outside
//   products M
//   product NI NS  i_1 .. i_NI  s_1 .. s_NS          (0-based primitive indices)
//
// Output in OUTDIR, per variant V:
//   V.depth   W*H little-endian float32: window depth (0 near .. 1 far), row 0 on top
//   V.prim    W*H little-endian uint16: 1-based primitive index, 0 background
//   results.txt  one line per variant:
//     variant V frames N median_ms X min_ms X max_ms X renderer "..."
//   and a line "convexity c_1 .. c_N" (as used).
//
// A frame is: clear; per product, OpenCSG::render (skipped for a product of one
// intersected primitive, which is drawn directly), then GL_EQUAL shading of the
// product's primitives (intersected with back faces culled, subtracted with front
// faces culled). Shading writes the primitive index as a flat colour, which is
// what the comparison needs; OpenSCAD's lit shading costs the same draws.
// Wall time per frame is bracketed by glFinish.

#include <GL/glew.h>
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <opencsg.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace {

[[noreturn]] void die(const std::string& msg) {
    std::fprintf(stderr, "opencsg-bench: %s\n", msg.c_str());
    std::exit(1);
}

struct Prim {
    unsigned convexity = 1;
    unsigned char rgb[3] = {0, 0, 0};
    float box[6] = {-1, -1, -1, 1, 1, 1};
    std::vector<float> tris;
    GLuint vbo = 0;
};

struct Product {
    std::vector<int> inter, sub;
};

struct Scene {
    int w = 0, h = 0;
    float view[16], proj[16];
    std::vector<Prim> prims;
    std::vector<Product> products;
};

Scene read_scene(const char* path) {
    std::ifstream in(path);
    if (!in) die(std::string("cannot read ") + path);
    Scene s;
    std::string tag;
    int version = 0;
    auto expect = [&](const char* want) {
        if (!(in >> tag) || tag != want)
            die(std::string(path) + ": expected '" + want + "', found '" + tag + "'");
    };
    expect("peeltrim-opencsg");
    in >> version;
    if (version != 1) die(std::string(path) + ": unsupported version");
    expect("size");
    in >> s.w >> s.h;
    if (s.w <= 0 || s.h <= 0 || s.w > 16384 || s.h > 16384) die("bad image size");
    expect("view");
    for (float& v : s.view) in >> v;
    expect("proj");
    for (float& v : s.proj) in >> v;
    expect("prims");
    size_t n = 0;
    in >> n;
    s.prims.resize(n);
    for (Prim& p : s.prims) {
        expect("prim");
        int r, g, b;
        size_t t;
        in >> p.convexity >> r >> g >> b;
        p.rgb[0] = r, p.rgb[1] = g, p.rgb[2] = b;
        for (float& v : p.box) in >> v;
        in >> t;
        p.tris.resize(9 * t);
        for (float& v : p.tris) in >> v;
    }
    expect("products");
    in >> n;
    s.products.resize(n);
    for (Product& q : s.products) {
        expect("product");
        size_t ni, ns;
        in >> ni >> ns;
        q.inter.resize(ni);
        q.sub.resize(ns);
        for (int& i : q.inter) in >> i;
        for (int& i : q.sub) in >> i;
        for (int i : q.inter)
            if (i < 0 || size_t(i) >= s.prims.size()) die("primitive index out of range");
        for (int i : q.sub)
            if (i < 0 || size_t(i) >= s.prims.size()) die("primitive index out of range");
    }
    if (!in) die(std::string(path) + ": truncated or malformed");
    return s;
}

void draw_mesh(const Prim& p) {
    glBindBuffer(GL_ARRAY_BUFFER, p.vbo);
    glEnableClientState(GL_VERTEX_ARRAY);
    glVertexPointer(3, GL_FLOAT, 0, nullptr);
    glDrawArrays(GL_TRIANGLES, 0, GLsizei(p.tris.size() / 3));
    glDisableClientState(GL_VERTEX_ARRAY);
    glBindBuffer(GL_ARRAY_BUFFER, 0);
}

class MeshPrim : public OpenCSG::Primitive {
public:
    MeshPrim(const Prim& p, OpenCSG::Operation op)
        : OpenCSG::Primitive(op, p.convexity), p_(p) {}
    void render() override { draw_mesh(p_); }

private:
    const Prim& p_;
};

// EGL: the default display (NVIDIA and other hardware drivers), or Mesa's
// surfaceless platform where no window system is running (llvmpipe here).
void init_egl() {
    const char* want = std::getenv("OPENCSG_BENCH_EGL");  // "default" | "surfaceless"
    EGLDisplay dpy = EGL_NO_DISPLAY;
    auto try_init = [&](EGLDisplay d) {
        EGLint major, minor;
        return d != EGL_NO_DISPLAY && eglInitialize(d, &major, &minor);
    };
    if (!want || std::strcmp(want, "surfaceless") != 0) {
        EGLDisplay d = eglGetDisplay(EGL_DEFAULT_DISPLAY);
        if (try_init(d)) dpy = d;
    }
    if (dpy == EGL_NO_DISPLAY && (!want || std::strcmp(want, "default") != 0)) {
        auto get_platform_display =
            (PFNEGLGETPLATFORMDISPLAYEXTPROC)eglGetProcAddress("eglGetPlatformDisplayEXT");
        if (get_platform_display) {
            EGLDisplay d = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA,
                                                EGL_DEFAULT_DISPLAY, nullptr);
            if (try_init(d)) dpy = d;
        }
    }
    if (dpy == EGL_NO_DISPLAY) die("no EGL display (tried the default and Mesa surfaceless)");
    if (!eglBindAPI(EGL_OPENGL_API)) die("eglBindAPI(EGL_OPENGL_API) failed");
    const EGLint attrs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE,
                            EGL_PBUFFER_BIT, EGL_NONE};
    const EGLint any[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE,
                          EGL_DONT_CARE, EGL_NONE};
    EGLConfig cfg;
    EGLint n = 0;
    if ((!eglChooseConfig(dpy, attrs, &cfg, 1, &n) || n == 0) &&
        (!eglChooseConfig(dpy, any, &cfg, 1, &n) || n == 0))
        die("no EGL config for desktop OpenGL");
    // OpenCSG 1.5 uses fixed function and ARB programs: a compatibility context.
    const EGLint ctx_attrs[] = {EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                EGL_CONTEXT_OPENGL_COMPATIBILITY_PROFILE_BIT, EGL_NONE};
    EGLContext ctx = eglCreateContext(dpy, cfg, EGL_NO_CONTEXT, ctx_attrs);
    if (ctx == EGL_NO_CONTEXT) die("eglCreateContext failed");
    if (!eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx))
        die("eglMakeCurrent without a surface failed");
    glewExperimental = GL_TRUE;
    GLenum err = glewInit();
    // GLEW built for GLX reports the missing GLX display after loading every
    // entry point; under EGL that is expected.
    if (err != GLEW_OK && err != GLEW_ERROR_NO_GLX_DISPLAY)
        die(std::string("glewInit: ") + (const char*)glewGetErrorString(err));
}

// The view's convexity of a mesh: the most front faces along any pixel's ray,
// counted in the stencil buffer.
unsigned measure_convexity(const Scene& s, const Prim& p) {
    glClearStencil(0);
    glClear(GL_STENCIL_BUFFER_BIT);
    glDisable(GL_DEPTH_TEST);
    glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
    glEnable(GL_STENCIL_TEST);
    glStencilFunc(GL_ALWAYS, 0, 0xff);
    glStencilOp(GL_KEEP, GL_KEEP, GL_INCR);
    draw_mesh(p);
    std::vector<unsigned char> st(size_t(s.w) * s.h);
    glReadPixels(0, 0, s.w, s.h, GL_STENCIL_INDEX, GL_UNSIGNED_BYTE, st.data());
    glDisable(GL_STENCIL_TEST);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glEnable(GL_DEPTH_TEST);
    unsigned m = 1;
    for (unsigned char c : st) m = std::max(m, unsigned(c));
    return m;
}

void set_id_colour(int i) {
    unsigned id = unsigned(i) + 1;
    glColor4ub(GLubyte(id & 0xff), GLubyte(id >> 8), 0, 255);
}

void render_frame(const Scene& s, const std::vector<std::vector<OpenCSG::Primitive*>>& prods) {
    glClearColor(0, 0, 0, 0);
    glClearDepth(1.0);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT | GL_STENCIL_BUFFER_BIT);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glEnable(GL_CULL_FACE);
    for (size_t k = 0; k < s.products.size(); ++k) {
        const Product& q = s.products[k];
        bool single = q.inter.size() == 1 && q.sub.empty();
        if (!single) {
            OpenCSG::render(prods[k]);
            glDepthFunc(GL_EQUAL);
        }
        glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
        glCullFace(GL_BACK);
        for (int i : q.inter) {
            set_id_colour(i);
            draw_mesh(s.prims[i]);
        }
        glCullFace(GL_FRONT);
        for (int i : q.sub) {
            set_id_colour(i);
            draw_mesh(s.prims[i]);
        }
        glDepthFunc(GL_LESS);
    }
}

double now_ms() {
    using namespace std::chrono;
    return duration<double, std::milli>(steady_clock::now().time_since_epoch()).count();
}

void write_file(const std::string& path, const void* data, size_t bytes) {
    FILE* f = std::fopen(path.c_str(), "wb");
    if (!f || std::fwrite(data, 1, bytes, f) != bytes || std::fclose(f) != 0)
        die("cannot write " + path);
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 3) {
        std::fprintf(stderr,
                     "usage: opencsg-bench SCENE.txt OUTDIR [--frames N] [--warmup N] "
                     "[--no-bbox] [--variants scs,goldfeather,automatic]\n");
        return 2;
    }
    int frames = 10, warmup = 2;
    bool bbox = true;
    std::string variants = "scs,goldfeather,automatic";
    for (int i = 3; i < argc; ++i) {
        std::string a = argv[i];
        auto value = [&]() -> std::string {
            if (i + 1 >= argc) die("missing value after " + a);
            return argv[++i];
        };
        if (a == "--frames") frames = std::max(1, std::atoi(value().c_str()));
        else if (a == "--warmup") warmup = std::max(0, std::atoi(value().c_str()));
        else if (a == "--no-bbox") bbox = false;
        else if (a == "--variants") variants = value();
        else die("unknown option " + a);
    }
    Scene s = read_scene(argv[1]);
    std::string out = argv[2];
    init_egl();
    std::string renderer = (const char*)glGetString(GL_RENDERER);

    GLuint fbo, rb[2];
    glGenFramebuffers(1, &fbo);
    glGenRenderbuffers(2, rb);
    glBindRenderbuffer(GL_RENDERBUFFER, rb[0]);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, s.w, s.h);
    glBindRenderbuffer(GL_RENDERBUFFER, rb[1]);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH24_STENCIL8, s.w, s.h);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, rb[0]);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER,
                              rb[1]);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
        die("framebuffer incomplete");
    glViewport(0, 0, s.w, s.h);
    glMatrixMode(GL_PROJECTION);
    glLoadMatrixf(s.proj);
    glMatrixMode(GL_MODELVIEW);
    glLoadMatrixf(s.view);
    glDisable(GL_LIGHTING);
    glShadeModel(GL_FLAT);

    for (Prim& p : s.prims) {
        glGenBuffers(1, &p.vbo);
        glBindBuffer(GL_ARRAY_BUFFER, p.vbo);
        glBufferData(GL_ARRAY_BUFFER, p.tris.size() * sizeof(float), p.tris.data(),
                     GL_STATIC_DRAW);
        glBindBuffer(GL_ARRAY_BUFFER, 0);
        if (p.convexity == 0) p.convexity = measure_convexity(s, p);
    }

    std::vector<std::unique_ptr<MeshPrim>> owned;
    std::vector<std::vector<OpenCSG::Primitive*>> prods;
    for (const Product& q : s.products) {
        std::vector<OpenCSG::Primitive*> v;
        auto add = [&](int i, OpenCSG::Operation op) {
            owned.push_back(std::make_unique<MeshPrim>(s.prims[i], op));
            const float* b = s.prims[i].box;
            // The NDC box lets OpenCSG scissor and batch; OpenSCAD leaves it unset.
            if (bbox) owned.back()->setBoundingBox(b[0], b[1], b[2], b[3], b[4], b[5]);
            v.push_back(owned.back().get());
        };
        for (int i : q.inter) add(i, OpenCSG::Intersection);
        for (int i : q.sub) add(i, OpenCSG::Subtraction);
        prods.push_back(v);
    }

    OpenCSG::setOption(OpenCSG::OffscreenSetting, OpenCSG::FrameBufferObject);
    std::ofstream results(out + "/results.txt");
    if (!results) die("cannot write " + out + "/results.txt");
    results << "convexity";
    for (const Prim& p : s.prims) results << ' ' << p.convexity;
    results << '\n';

    std::stringstream list(variants);
    std::string v;
    while (std::getline(list, v, ',')) {
        if (v == "scs") {
            OpenCSG::setOption(OpenCSG::AlgorithmSetting, OpenCSG::SCS);
            OpenCSG::setOption(OpenCSG::DepthComplexitySetting, OpenCSG::OcclusionQuery);
        } else if (v == "goldfeather") {
            OpenCSG::setOption(OpenCSG::AlgorithmSetting, OpenCSG::Goldfeather);
            OpenCSG::setOption(OpenCSG::DepthComplexitySetting, OpenCSG::OcclusionQuery);
        } else if (v == "automatic") {
            // Automatic also chooses the depth complexity strategy itself.
            OpenCSG::setOption(OpenCSG::AlgorithmSetting, OpenCSG::Automatic);
        } else {
            die("unknown variant " + v + " (scs, goldfeather, automatic)");
        }
        for (int i = 0; i < warmup; ++i) render_frame(s, prods);
        std::vector<double> ms;
        for (int i = 0; i < frames; ++i) {
            glFinish();
            double t0 = now_ms();
            render_frame(s, prods);
            glFinish();
            ms.push_back(now_ms() - t0);
        }
        GLenum err = glGetError();
        if (err != GL_NO_ERROR) die("GL error " + std::to_string(err) + " in variant " + v);
        std::vector<double> sorted = ms;
        std::sort(sorted.begin(), sorted.end());
        double median = sorted.size() % 2 ? sorted[sorted.size() / 2]
                                          : 0.5 * (sorted[sorted.size() / 2 - 1] +
                                                   sorted[sorted.size() / 2]);
        // Read back (outside the timed frames); GL's row 0 is the bottom.
        size_t n = size_t(s.w) * s.h;
        std::vector<float> depth(n), dflip(n);
        std::vector<unsigned char> rgba(4 * n);
        std::vector<unsigned short> prim(n);
        glReadPixels(0, 0, s.w, s.h, GL_DEPTH_COMPONENT, GL_FLOAT, depth.data());
        glReadPixels(0, 0, s.w, s.h, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
        for (int y = 0; y < s.h; ++y)
            for (int x = 0; x < s.w; ++x) {
                size_t src = size_t(s.h - 1 - y) * s.w + x, dst = size_t(y) * s.w + x;
                dflip[dst] = depth[src];
                prim[dst] = rgba[4 * src] | (rgba[4 * src + 1] << 8);
            }
        write_file(out + "/" + v + ".depth", dflip.data(), n * sizeof(float));
        write_file(out + "/" + v + ".prim", prim.data(), n * sizeof(unsigned short));
        results << "variant " << v << " frames " << frames << " median_ms " << median
                << " min_ms " << sorted.front() << " max_ms " << sorted.back()
                << " renderer \"" << renderer << "\"\n";
    }
    OpenCSG::freeResources();
    return 0;
}
