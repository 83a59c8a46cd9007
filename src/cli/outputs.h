/*
 * outputs.h - a render's outputs, committed together, and the signals that
 * stop it cleanly.
 *
 *     outputs_catch_signals();
 *     ... render, passing &outputs_stop as the render's stop flag ...
 *     const char *tmp = outputs_add("out.exr");   then write into tmp
 *     if (outputs_stopped()) outputs_abort(); else outputs_commit();
 *
 * The first SIGINT or SIGTERM sets outputs_stop to its number: the render
 * leaves its rows, and outputs_save_partial keeps the rows done. A second
 * one removes every temporary file of the set and exits at once, 128 plus
 * its number. A signal ignored at start stays ignored.
 */
#ifndef LANCER_CLI_OUTPUTS_H
#define LANCER_CLI_OUTPUTS_H

#include <signal.h>
#include <stddef.h>

#include "lancer/image.h"

/* 0, or the number of the signal that asked the render to stop: the
 * render's stop flag (stop.h), which outputs_stopped reads. */
extern volatile sig_atomic_t outputs_stop;
int outputs_stopped(void);

/* Installs the handler for SIGINT and SIGTERM. */
void outputs_catch_signals(void);

/* Adds path to the run's set of outputs (afile.h): returns the temporary
 * file to write into, or NULL after a message. */
const char *outputs_add(const char *path);

/* Puts every output of the set in place, or none. Returns 0, or -1 after a
 * message. */
int outputs_commit(void);

/* Removes the set's temporary files. */
void outputs_abort(void);

/* Writes img into the set's temporary files exr (in precision prec, with
 * the nattrs attributes) and, when png is not NULL, png; messages name
 * exr_name and png_name, the files the user knows. The two take about as
 * long to compress: with more than one of `threads`, side by side, the
 * EXR's chunks on the threads the PNG leaves (the same bytes either way).
 * Returns 0, or -1 after a message. */
int outputs_write_images(const Image *img, const char *exr, const char *exr_name, ImagePrecision prec,
                         const ImageAttr *attrs, int nattrs, const char *png, const char *png_name, int threads);

/* The partial image's name: "<exr without .exr>.partial.exr" into buf.
 * Returns 0, or -1 after a message. */
int outputs_partial_name(const char *exr, char *buf, size_t len);

/* Writes the finished rows of a stopped render (done[y] for each row y of
 * img) to `partial`, in 32-bit floats, the other rows black, the finished
 * ones listed in its header ("lancer:rows", inclusive ranges such as
 * "0-143,150") beside the nattrs attributes given (the render's stamp);
 * says so on stderr, after `lead`. Writes nothing when no row is done.
 * Returns the exit status: 128 + the signal, or 1 when the partial image
 * cannot be written. */
int outputs_save_partial(const ImageAttr *attrs, int nattrs, const char *exr, const char *partial, Image *img,
                         const unsigned char *done, const char *lead);

/* Reads a partial image's "lancer:rows" into done (h flags, which it
 * clears first). Returns 0, or -1 when the list is malformed or names a
 * row outside 0..h-1. */
int outputs_parse_rows(const char *rows, unsigned char *done, int h);

#endif
