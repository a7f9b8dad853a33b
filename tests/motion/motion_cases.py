"""Activity groups of the motion tests (activity-library files of this room)."""

# Activity files of this room: HAPT, the 12 controllability activities of UTD-MHAD, jumping jacks,
# the other UTD-MHAD activities, MM-Fit and PAMAP2.
HAPT = ("walking", "walking_upstairs", "walking_downstairs", "sitting", "standing", "lying",
        "stand_to_sit", "sit_to_stand", "sit_to_lie", "lie_to_sit", "stand_to_lie", "lie_to_stand")
CONTROLLABILITY = ("right_hand_wave", "two_hand_front_clap", "right_arm_throw", "basketball_shoot",
                   "right_hand_draw_circle_clockwise", "front_boxing", "two_arm_curl", "two_hand_push",
                   "jogging_in_place", "walking_in_place", "forward_lunge", "squat_arms_extended")
UTD_MHAD_OTHERS = ("right_arm_swipe_left", "right_arm_swipe_right", "cross_arms_in_chest", "right_hand_draw_x",
                   "right_hand_draw_circle_counter_clockwise", "draw_triangle", "bowling", "baseball_swing",
                   "tennis_forehand_swing", "tennis_serve", "right_hand_knock", "right_hand_catch",
                   "pick_up_and_throw")
MMFIT = ("squats", "lunges", "bicep_curls", "situps", "pushups", "tricep_extensions", "dumbbell_rows",
         "dumbbell_shoulder_press", "lateral_shoulder_raises")
PAMAP2 = ("running", "cycling", "nordic_walking", "watching_tv", "computer_work", "car_driving",
          "vacuum_cleaning", "ironing", "folding_laundry", "house_cleaning", "playing_soccer", "rope_jumping")
AUTHORED = HAPT + CONTROLLABILITY + ("jumping_jacks",) + UTD_MHAD_OTHERS + MMFIT + PAMAP2
DURATION_ACTIVITIES = ("right_arm_throw", "basketball_shoot", "two_hand_push", "forward_lunge")
SYMMETRY_ACTIVITIES = ("two_hand_front_clap", "two_arm_curl", "two_hand_push", "squat_arms_extended")
# every activity whose SMP lists `symmetry` as variant (an asymmetric execution keeps the label)
SYMMETRY_VARIANT = SYMMETRY_ACTIVITIES + ("squats", "bicep_curls", "dumbbell_rows", "dumbbell_shoulder_press",
                                          "lateral_shoulder_raises")
REPETITION_ACTIVITIES = ("right_hand_wave", "two_hand_front_clap", "right_hand_draw_circle_clockwise",
                         "front_boxing", "two_arm_curl", "jogging_in_place", "walking_in_place",
                         "squat_arms_extended")
