/* Plots of persistence diagrams drawn with cairo (C API): the persistence diagram
 * (birth against death, the diagonal, points coloured by dimension with a legend,
 * essential classes on an "inf" line at the top — or "-inf" at the bottom for superlevel
 * diagrams whose essential deaths are −inf) and the barcode (bars sorted by dimension,
 * then by persistence, longest first). The format follows the extension: .png or .svg.
 * Files are written atomically. Users of these functions link cairo
 * (PkgConfig::CAIRO). */
#ifndef MGS_DIAGRAM_PLOT_H
#define MGS_DIAGRAM_PLOT_H
#include "topo/mgs_diagram.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Barcodes with more bars than this show the most persistent ones (the title says so). */
#define MGS_PLOT_MAX_BARS 3000

mgs_status mgs_diagram_plot(const mgs_diagram *d, const char *path, const char *title,
                            mgs_error *err);
mgs_status mgs_diagram_plot_barcode(const mgs_diagram *d, const char *path, const char *title,
                                    mgs_error *err);

/* Frees cairo's and fontconfig's process-wide caches (call once at exit, after the last
 * plot, so leak checkers see a clean exit). */
void mgs_diagram_plot_release(void);

#ifdef __cplusplus
}
#endif
#endif
