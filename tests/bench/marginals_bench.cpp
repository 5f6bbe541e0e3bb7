// Marginal restoration on the shared photos: the 1-D Wasserstein distance between the
// exemplar's and the noise's marginals along the exemplar's principal colour directions, and the
// power-spectrum RME of the noise, without (gaussian) and with (exemplar) restoration.
//   marginals_bench [SEEDS]    (texton r = 64, level-0 windows of the exemplar's size, CPU)
#include "tests/render/marginal_fidelity.h"
#include "tests/support/test_support.h"

#include <cstdio>
#include <cstdlib>

int main(int argc, char** argv) {
    const int seeds = argc > 1 ? std::atoi(argv[1]) : 3;
    std::printf(
        "| photo | W1 gaussian | W1 exemplar | W1 ratio | RME gaussian | RME exemplar | RME "
        "growth |\n|---|---|---|---|---|---|---|\n");
    for (const char* name : {"skimage_gravel.png", "skimage_grass.png", "skimage_brick.png",
                             "mypaint_HR_Cork.png", "mypaint_HR_DecoPaper.png", "etr_sand01.png",
                             "etr_pebbles04.png", "etr_floor01.png", "etr_pave02.png"}) {
        const auto f =
            textond::test::marginal_fidelity(textond::test::load_exemplar(name), 64, seeds);
        std::printf("| %s | %.5f | %.5f | %.1fx | %.3f | %.3f | %+.3f |\n", name, f.w1_gaussian,
                    f.w1_exemplar, f.w1_gaussian / f.w1_exemplar, f.rme_gaussian, f.rme_exemplar,
                    f.rme_exemplar - f.rme_gaussian);
        std::fflush(stdout);
    }
    return 0;
}
