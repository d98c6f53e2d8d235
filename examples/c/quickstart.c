#include <dynaslice.h>
#include <stdio.h>

int main(int argc, char **argv) {
    DsModel *model = NULL;
    int rc = ds_model_open(argc > 1 ? argv[1] : "model.dsm", &model);
    if (rc != DS_OK) {
        fprintf(stderr, "%s: %s\n", ds_error_string(rc), ds_last_error_message());
        return 1;
    }
    char name[DS_MAX_NAME_LEN + 1];
    int32_t label = 0;
    uint32_t k = ds_num_classes(model), at_centre = 0;
    printf("%u classes\n", k);
    for (uint32_t c = 1; c <= k && ds_class_name(model, c, name, sizeof name) >= 0; c++)
        if (ds_class_label(model, c, &label) == DS_OK) printf("class %u: %s (label %d)\n", c, name, label);
    float lo[3], hi[3], t0, t1, sdf[DS_MAX_CLASSES];
    ds_bounds(model, lo, hi);
    ds_time_range(model, &t0, &t1);
    const float centre[3] = {(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2};
    ds_eval(model, centre, t0, sdf, DS_MAX_CLASSES);
    ds_label(model, centre, t0, &at_centre);
    printf("f1 = %g mm, label at the centre: %u\n", sdf[0], at_centre);
    ds_model_free(model);
    return 0;
}
