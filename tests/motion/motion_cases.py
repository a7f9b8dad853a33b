"""Activity groups of the motion tests (activity-library files of this room)."""

# Activity files of this room (HAPT, the 12 controllability activities of UTD-MHAD, jumping jacks).
HAPT = ("walking", "walking_upstairs", "walking_downstairs", "sitting", "standing", "lying",
        "stand_to_sit", "sit_to_stand", "sit_to_lie", "lie_to_sit", "stand_to_lie", "lie_to_stand")
CONTROLLABILITY = ("right_hand_wave", "two_hand_front_clap", "right_arm_throw", "basketball_shoot",
                   "right_hand_draw_circle_clockwise", "front_boxing", "two_arm_curl", "two_hand_push",
                   "jogging_in_place", "walking_in_place", "forward_lunge", "squat_arms_extended")
AUTHORED = HAPT + CONTROLLABILITY + ("jumping_jacks",)
DURATION_ACTIVITIES = ("right_arm_throw", "basketball_shoot", "two_hand_push", "forward_lunge")
SYMMETRY_ACTIVITIES = ("two_hand_front_clap", "two_arm_curl", "two_hand_push", "squat_arms_extended")
REPETITION_ACTIVITIES = ("right_hand_wave", "two_hand_front_clap", "right_hand_draw_circle_clockwise",
                         "front_boxing", "two_arm_curl", "jogging_in_place", "walking_in_place",
                         "squat_arms_extended")
